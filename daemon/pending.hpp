#pragma once
// Finished events on their way to the store. An event is written to a journal file (CBOR in a
// directory beside the store: written to a temporary name, fsync'ed, renamed, the directory
// fsync'ed) the moment it closes, before it is fitted; the file goes only once its commit went
// through. So a kill -9 at any point after the close leaves either the stored row or the file,
// and a restart commits each file once (a row with the file's uid is taken as already stored).
//
// While the store fails (locked by another process, read-only, full) events wait here, oldest
// first; `hold_in_memory` of them keep a loaded copy, the rest are read back from their files.
// An event whose journal file could not be written (the directory fails too) waits in memory
// only, up to `max_in_memory`; beyond that the oldest are dropped, counted in lost() and logged.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include "daemon/record.hpp"

namespace brakefit::daemon {

/// A spill or journal file larger than this is refused (moved aside), never read into memory.
inline constexpr std::size_t kMaxSpillFileBytes = 256u << 20;

/// Reads one spill file: a regular file only (a symlink, FIFO or device is refused without being
/// followed or opened for reading), at most max_bytes, CBOR nested at most a few levels. Throws
/// InputError naming the path and what is wrong.
EventRecord read_spill_file(const std::string& path, std::size_t max_bytes = kMaxSpillFileBytes);

class PendingEvents {
 public:
  PendingEvents(std::string spill_dir, std::size_t hold_in_memory, std::size_t max_in_memory);

  /// Creates the directory and writes, syncs and removes a probe file there; throws
  /// std::runtime_error naming the directory and the system's reason. brakefitd refuses to start
  /// on it: without a journal a kill would lose the event being committed.
  void check_writable() const;
  /// Files left by an earlier run (oldest first); call once at start. Names that are not a
  /// regular file are moved aside as NAME.bad.
  std::size_t adopt_spilled();
  /// Writes the record to a new journal file, durably; returns its path, or "" (logged) when the
  /// file could not be written.
  std::string journal(const EventRecord& r);
  /// Queues a record whose journal file is `path` ("" for none: it waits in memory only).
  void push(EventRecord r, std::string path);
  /// The store failed: records beyond hold_in_memory drop their loaded copy (their file keeps
  /// them) and records without a file are written to one (oldest first).
  void spill_excess();
  /// The oldest waiting event (nullptr when none), read from its file when not in memory. A file
  /// that cannot be read is moved aside as NAME.bad with an error, and the next one is tried.
  const EventRecord* front();
  /// Replaces the front's record (the daemon fits a journaled event that closed before a crash).
  void replace_front(EventRecord r);
  bool front_is_spilled() const;
  /// The front cannot be committed at all (a journaled event that cannot be fitted): its file is
  /// moved aside as NAME.bad, logged with why, and counted lost.
  void drop_front_aside(const std::string& why);
  /// The front was committed: forget it (deletes its file).
  void pop();
  /// Writes every record that has no file yet (a clean stop); returns how many could not be
  /// written, which are then counted lost.
  std::size_t spill_all();

  std::size_t size() const { return entries_.size(); }
  /// Waiting events that are on disk.
  std::size_t spilled() const;
  std::uint64_t lost() const { return lost_; }
  const std::string& dir() const { return dir_; }

 private:
  struct Entry {
    std::string path;                ///< "" while it has no file
    std::optional<EventRecord> rec;  ///< loaded copy
    bool file_fitted = false;        ///< the file holds the fitted record, not only the closed one
  };
  std::string next_path(const EventRecord& r);
  void move_aside(const std::string& path, const std::string& why);
  std::string dir_;
  std::size_t hold_, cap_;
  std::deque<Entry> entries_;
  std::uint64_t next_file_ = 1, lost_ = 0;
};

}  // namespace brakefit::daemon
