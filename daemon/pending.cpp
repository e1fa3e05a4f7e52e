#include "daemon/pending.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "core/curve.hpp"

namespace brakefit::daemon {

namespace fs = std::filesystem;

namespace {

bool write_all(int fd, const std::string& bytes) {
  std::size_t off = 0;
  while (off < bytes.size()) {
    const auto n = ::write(fd, bytes.data() + off, bytes.size() - off);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    off += static_cast<std::size_t>(n);
  }
  return true;
}

void sync_dir(const std::string& dir) {
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

/// tmp written, fsync'ed, renamed over path, the directory fsync'ed: the file is whole or absent.
bool write_durably(const std::string& path, const std::string& bytes, std::string& err) {
  const std::string tmp = path + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0640);
  if (fd < 0) {
    err = fmt::format("{}: {}", tmp, std::strerror(errno));
    return false;
  }
  if (!write_all(fd, bytes) || ::fsync(fd) != 0) {
    err = fmt::format("{}: {}", tmp, std::strerror(errno));
    ::close(fd);
    ::unlink(tmp.c_str());
    return false;
  }
  if (::close(fd) != 0 || ::rename(tmp.c_str(), path.c_str()) != 0) {
    err = fmt::format("{}: {}", path, std::strerror(errno));
    ::unlink(tmp.c_str());
    return false;
  }
  sync_dir(fs::path(path).parent_path().string());
  return true;
}

const char* file_kind(mode_t m) {
  if (S_ISLNK(m)) return "a symbolic link";
  if (S_ISFIFO(m)) return "a FIFO";
  if (S_ISCHR(m) || S_ISBLK(m)) return "a device";
  if (S_ISSOCK(m)) return "a socket";
  if (S_ISDIR(m)) return "a directory";
  return "not a regular file";
}

}  // namespace

EventRecord read_spill_file(const std::string& path, std::size_t max_bytes) {
  // O_NOFOLLOW: a link is refused, not followed; O_NONBLOCK: a FIFO does not hang the open.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    struct stat l {};
    if (errno == ELOOP && ::lstat(path.c_str(), &l) == 0)
      throw InputError(
          fmt::format("{}: {}, not a spill file (not followed)", path, file_kind(l.st_mode)));
    throw InputError(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  }
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0)
    throw InputError(fmt::format("{}: cannot stat: {}", path, std::strerror(errno)));
  if (!S_ISREG(st.st_mode))
    throw InputError(fmt::format("{}: {}, not a spill file", path, file_kind(st.st_mode)));
  if (static_cast<std::uint64_t>(st.st_size) > max_bytes)
    throw InputError(fmt::format("{}: {} bytes, more than a spill file holds ({} at most)", path,
                                 st.st_size, max_bytes));
  std::string bytes(static_cast<std::size_t>(st.st_size), '\0');
  std::size_t off = 0;
  while (off < bytes.size()) {
    const auto n = ::read(fd, bytes.data() + off, bytes.size() - off);
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (n < 0) throw InputError(fmt::format("{}: cannot read: {}", path, std::strerror(errno)));
    if (n == 0) break;  // shrank while read: the CBOR reader names what is missing
    off += static_cast<std::size_t>(n);
  }
  bytes.resize(off);
  return record_from_cbor(bytes, path);
}

PendingEvents::PendingEvents(std::string spill_dir, std::size_t hold_in_memory,
                             std::size_t max_in_memory)
    : dir_(std::move(spill_dir)),
      hold_(hold_in_memory),
      cap_(std::max<std::size_t>(1, max_in_memory)) {}

void PendingEvents::check_writable() const {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_, ec))
    throw std::runtime_error(fmt::format("{}: cannot create the spill directory: {}", dir_,
                                         ec ? ec.message() : "exists and is not a directory"));
  const std::string probe = (fs::path(dir_) / fmt::format(".probe-{}", ::getpid())).string();
  std::string err;
  ::unlink((probe + ".tmp").c_str());
  if (!write_durably(probe, "probe", err))
    throw std::runtime_error(fmt::format("{}: cannot write the spill directory: {}", dir_, err));
  ::unlink(probe.c_str());
}

void PendingEvents::move_aside(const std::string& path, const std::string& why) {
  std::error_code ec;
  fs::rename(path, path + ".bad", ec);
  if (ec)
    spdlog::error("{} (and it cannot be moved aside: {}; skipped)", why, ec.message());
  else
    spdlog::error("{} (moved aside as {}.bad)", why, path);
}

std::size_t PendingEvents::adopt_spilled() {
  std::error_code ec;
  if (!fs::is_directory(dir_, ec)) return 0;
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir_, ec)) {
    const auto name = e.path().filename().string();
    if (e.path().extension() == ".tmp" && fs::is_regular_file(e.symlink_status(ec))) {
      fs::remove(e.path(), ec);  // a write a kill cut short: never renamed, so never a record
      continue;
    }
    if (e.path().extension() != ".cbor") continue;
    // symlink_status: a link is judged as itself, never by what it points to.
    struct stat l {};
    if (::lstat(e.path().c_str(), &l) == 0 && !S_ISREG(l.st_mode)) {
      move_aside(e.path().string(), fmt::format("{}: {}, not a spill file (not opened)",
                                                e.path().string(), file_kind(l.st_mode)));
      continue;
    }
    names.push_back(name);
  }
  std::sort(names.begin(), names.end());  // zero-padded sequence numbers: oldest first
  for (const auto& n : names) {
    entries_.push_back({(fs::path(dir_) / n).string(), std::nullopt, false});
    try {
      next_file_ = std::max<std::uint64_t>(next_file_, std::stoull(n) + 1);
    } catch (const std::exception&) {  // a name of its own: it still waits in sorted order
    }
  }
  return names.size();
}

std::string PendingEvents::next_path(const EventRecord& r) {
  // The uid in the name: two writers (which the instance lock forbids) could never overwrite
  // each other's file; the sequence number keeps the order.
  return (fs::path(dir_) / fmt::format("{:020d}-{}.cbor", next_file_, r.uid)).string();
}

std::string PendingEvents::journal(const EventRecord& r) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  std::string path = next_path(r);
  std::string err;
  if (ec || !write_durably(path, record_to_cbor(r), err)) {
    spdlog::error("cannot journal event (pipeline id {}) to {}: {}", r.pipeline_event_id, dir_,
                  ec ? ec.message() : err);
    return {};
  }
  ++next_file_;  // only a file written takes a number: a failing directory leaves no gaps
  return path;
}

void PendingEvents::push(EventRecord r, std::string path) {
  entries_.push_back({std::move(path), std::move(r), false});
  std::size_t memory_only = 0;
  for (const auto& e : entries_) memory_only += e.path.empty();
  while (memory_only > cap_) {
    auto it = std::find_if(entries_.begin(), entries_.end(),
                           [](const Entry& e) { return e.path.empty(); });
    ++lost_;
    --memory_only;
    spdlog::error(
        "event (pipeline id {}) lost: the store and the spill directory {} both fail and "
        "{} events are already held in memory",
        it->rec->pipeline_event_id, dir_, cap_);
    entries_.erase(it);
  }
}

void PendingEvents::spill_excess() {
  const std::size_t n = entries_.size();
  for (std::size_t i = 0; i < n; ++i) {
    auto& e = entries_[i];
    if (n - i <= hold_) break;  // the newest hold_in_memory keep their copy
    if (!e.rec) continue;
    if (e.path.empty()) {
      if ((e.path = journal(*e.rec)).empty()) break;  // the directory fails: keep order
      spdlog::warn("event (pipeline id {}) spilled to {} until the store takes it",
                   e.rec->pipeline_event_id, e.path);
    } else if (!e.file_fitted) {
      // The journal holds the event as it closed; its fit goes over it (same name, same order),
      // so the copy in memory can go without the fit being made again.
      std::string err;
      if (!write_durably(e.path, record_to_cbor(*e.rec), err)) {
        spdlog::warn("{}: the fitted event stays in memory: {}", e.path, err);
        continue;
      }
    }
    e.file_fitted = true;
    e.rec.reset();
  }
}

const EventRecord* PendingEvents::front() {
  while (!entries_.empty()) {
    auto& e = entries_.front();
    if (e.rec) return &*e.rec;
    try {
      e.rec = read_spill_file(e.path);
      return &*e.rec;
    } catch (const std::exception& ex) {
      move_aside(e.path, ex.what());
      entries_.pop_front();
    }
  }
  return nullptr;
}

void PendingEvents::replace_front(EventRecord r) {
  if (!entries_.empty()) entries_.front().rec = std::move(r);
}

void PendingEvents::drop_front_aside(const std::string& why) {
  if (entries_.empty()) return;
  const Entry e = std::move(entries_.front());
  entries_.pop_front();
  ++lost_;
  const std::string what = fmt::format("event (pipeline id {}) not stored: {}",
                                       e.rec ? e.rec->pipeline_event_id : 0, why);
  if (e.path.empty())
    spdlog::error("{}", what);
  else
    move_aside(e.path, fmt::format("{}: {}", e.path, what));
}

bool PendingEvents::front_is_spilled() const {
  return !entries_.empty() && !entries_.front().path.empty();
}

void PendingEvents::pop() {
  if (entries_.empty()) return;
  const std::string path = entries_.front().path;
  entries_.pop_front();
  if (path.empty()) return;
  std::error_code ec;
  fs::remove(path, ec);
  if (ec) spdlog::error("{}: cannot remove the committed spill file: {}", path, ec.message());
}

std::size_t PendingEvents::spill_all() {
  std::size_t failed = 0;
  for (auto it = entries_.begin(); it != entries_.end();) {
    if (it->path.empty() && (it->path = journal(*it->rec)).empty()) {  // fitted when written
      ++failed;
      ++lost_;
      it = entries_.erase(it);
      continue;
    }
    ++it;
  }
  return failed;
}

std::size_t PendingEvents::spilled() const {
  return static_cast<std::size_t>(std::count_if(entries_.begin(), entries_.end(),
                                                [](const Entry& e) { return !e.path.empty(); }));
}

}  // namespace brakefit::daemon
