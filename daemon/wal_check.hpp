#pragma once
// Reads a SQLite write-ahead log the way SQLite's recovery will (https://sqlite.org/fileformat.html
// "The Write-Ahead Log"): the header and its checksum, then each frame's salts and cumulative
// checksum, up to the last commit frame. SQLite takes that prefix and silently ignores the rest, so
// a torn or overwritten log loses committed transactions without a word; brakefitd reads it first
// and keeps a copy of any log that does not end cleanly, saying so.
#include <cstdint>
#include <string>

namespace brakefit::daemon {

struct WalCheck {
  bool present = false;          ///< the file exists and is not empty
  std::uint64_t bytes = 0;       ///< its size
  std::uint64_t used_bytes = 0;  ///< header + frames up to the last commit: what SQLite replays
  std::uint64_t commits = 0;     ///< commit frames in that prefix
  /// Empty when the log ends cleanly: after its last commit only frames of an earlier generation
  /// (another salt) or nothing. Else what is wrong: a bad header, a frame failing its checksum,
  /// a partial frame, or frames written after the last commit that no commit closes.
  std::string problem;
};

/// Reads `wal_path` (missing: present false). Never throws on content; an unreadable file is a
/// problem.
WalCheck check_wal(const std::string& wal_path);

}  // namespace brakefit::daemon
