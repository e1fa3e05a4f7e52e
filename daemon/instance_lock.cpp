#include "daemon/instance_lock.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "core/exit_codes.hpp"

namespace brakefit::daemon {

InstanceLock::InstanceLock(const std::string& store_path) : path_(store_path + ".lock") {
  std::error_code ec;
  const auto dir = std::filesystem::path(path_).parent_path();
  if (!dir.empty()) std::filesystem::create_directories(dir, ec);
  fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
  // Another user's lock file (a run as root before the service's own user) still locks: flock
  // needs no write access.
  const int open_errno = errno;
  if (fd_ < 0 && open_errno == EACCES)
    fd_ = ::open(path_.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd_ < 0)
    throw ExitError(kExitCantCreate, fmt::format("{}: cannot create the store's lock file: {}",
                                                 path_, std::strerror(open_errno)));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    char buf[32] = {};
    const auto n = ::pread(fd_, buf, sizeof buf - 1, 0);
    ::close(fd_);
    fd_ = -1;
    if (err == EWOULDBLOCK) {
      std::string pid(buf, n > 0 ? static_cast<std::size_t>(n) : 0);
      while (!pid.empty() && (pid.back() == '\n' || pid.back() == ' ')) pid.pop_back();
      throw ExitError(kExitTempFail,
                      fmt::format("{}: another brakefitd{} uses this store; one store takes one "
                                  "daemon (give this one its own [store] path)",
                                  path_, pid.empty() ? "" : fmt::format(" (pid {})", pid)));
    }
    throw ExitError(kExitCantCreate, fmt::format("{}: cannot lock: {}", path_, std::strerror(err)));
  }
  // The pid is for a refused second instance's message only; the lock is what counts.
  const std::string pid = fmt::format("{}\n", ::getpid());
  [[maybe_unused]] const bool noted =
      ::ftruncate(fd_, 0) == 0 && ::pwrite(fd_, pid.data(), pid.size(), 0) >= 0;
}

InstanceLock::~InstanceLock() {
  if (fd_ >= 0) ::close(fd_);
}

}  // namespace brakefit::daemon
