#pragma once
// One brakefitd per store: an exclusive flock on STORE.lock, held for the process's life (the
// kernel drops it when the process dies, kill -9 included, so a stale file never blocks a
// start). A second instance on the same store is refused before it opens anything: two writers
// would interleave their journal files and publish each other's event ids.
#include <string>

namespace brakefit::daemon {

class InstanceLock {
 public:
  /// Takes the lock on `store_path + ".lock"` (creating it) and writes this process's pid into
  /// it. Throws ExitError 75 (kExitTempFail) naming the holder's pid when another process holds
  /// it, 73 when the file cannot be created.
  explicit InstanceLock(const std::string& store_path);
  ~InstanceLock();
  InstanceLock(const InstanceLock&) = delete;
  InstanceLock& operator=(const InstanceLock&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
};

}  // namespace brakefit::daemon
