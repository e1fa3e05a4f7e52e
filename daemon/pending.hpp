#pragma once
// Finished events the store has not taken yet. An event is published only after its commit, so
// while the store fails (locked by another process, read-only, full) events wait here, oldest
// first: in memory up to `hold_in_memory`, beyond that spilled to CBOR files in a directory beside
// the store (written to a temporary name, fsync'ed, renamed), where a restart finds them. Spilled
// files are always older than the events in memory, so the order of events is kept.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "daemon/store.hpp"

namespace brakefit::daemon {

class PendingEvents {
 public:
  /// spill_dir: created when the first event is spilled. hold_in_memory: events kept in memory
  /// before spilling; max_in_memory: hard cap when spilling itself fails (older events beyond it
  /// are dropped, counted in lost(), and logged).
  PendingEvents(std::string spill_dir, std::size_t hold_in_memory, std::size_t max_in_memory);

  /// Files left by an earlier run (oldest first); call once at start.
  std::size_t adopt_spilled();
  /// Held in memory; the caller tries to commit it at once and spills on failure.
  void push(EventRecord r);
  /// The store failed: everything in memory beyond hold_in_memory goes to files (oldest first).
  void spill_excess();
  /// The oldest waiting event (nullptr when none). A spilled file that cannot be read is moved
  /// aside as NAME.bad with an error, and the next one is tried.
  const EventRecord* front();
  bool front_is_spilled() const { return !files_.empty(); }
  /// The front was committed: forget it (deletes its file).
  void pop();
  /// Spills everything held in memory (on a clean stop, so nothing waits in memory alone).
  void spill_all();

  std::size_t size() const { return files_.size() + memory_.size(); }
  std::size_t spilled() const { return files_.size(); }
  std::uint64_t lost() const { return lost_; }
  const std::string& dir() const { return dir_; }

 private:
  bool spill(const EventRecord& r);
  std::string dir_;
  std::size_t hold_, cap_;
  std::deque<EventRecord> memory_;
  std::deque<std::string> files_;      ///< paths, oldest first
  std::optional<EventRecord> loaded_;  ///< files_.front() read
  std::uint64_t next_file_ = 1, lost_ = 0;
};

}  // namespace brakefit::daemon
