#include "daemon/pending.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace brakefit::daemon {

namespace fs = std::filesystem;

namespace {

bool write_durably(const std::string& path, const std::string& bytes, std::string& err) {
  const std::string tmp = path + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
  if (fd < 0) {
    err = fmt::format("{}: {}", tmp, std::strerror(errno));
    return false;
  }
  std::size_t off = 0;
  while (off < bytes.size()) {
    const auto n = ::write(fd, bytes.data() + off, bytes.size() - off);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      err = fmt::format("{}: {}", tmp, std::strerror(errno));
      ::close(fd);
      ::unlink(tmp.c_str());
      return false;
    }
    off += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    err = fmt::format("{}: {}", tmp, std::strerror(errno));
    ::unlink(tmp.c_str());
    return false;
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    err = fmt::format("{}: {}", path, std::strerror(errno));
    ::unlink(tmp.c_str());
    return false;
  }
  const int dfd = ::open(fs::path(path).parent_path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  return true;
}

}  // namespace

PendingEvents::PendingEvents(std::string spill_dir, std::size_t hold_in_memory,
                             std::size_t max_in_memory)
    : dir_(std::move(spill_dir)),
      hold_(hold_in_memory),
      cap_(std::max<std::size_t>(1, max_in_memory)) {}

std::size_t PendingEvents::adopt_spilled() {
  std::error_code ec;
  if (!fs::is_directory(dir_, ec)) return 0;
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir_, ec)) {
    const auto name = e.path().filename().string();
    if (e.path().extension() == ".cbor") names.push_back(name);
  }
  std::sort(names.begin(), names.end());  // zero-padded sequence numbers: oldest first
  for (const auto& n : names) {
    files_.push_back((fs::path(dir_) / n).string());
    try {
      next_file_ = std::max<std::uint64_t>(next_file_, std::stoull(n) + 1);
    } catch (...) {
    }
  }
  return names.size();
}

bool PendingEvents::spill(const EventRecord& r) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  const std::string path = (fs::path(dir_) / fmt::format("{:020d}.cbor", next_file_)).string();
  std::string err;
  if (ec || !write_durably(path, record_to_cbor(r), err)) {
    spdlog::error("cannot spill a waiting event to {}: {}", dir_, ec ? ec.message() : err);
    return false;
  }
  ++next_file_;
  files_.push_back(path);
  spdlog::warn("event (pipeline id {}) spilled to {} until the store takes it", r.pipeline_event_id,
               path);
  return true;
}

void PendingEvents::push(EventRecord r) {
  memory_.push_back(std::move(r));
  while (memory_.size() > cap_) {
    ++lost_;
    spdlog::error(
        "event (pipeline id {}) lost: the store and the spill directory {} both fail and "
        "{} events are already held in memory",
        memory_.front().pipeline_event_id, dir_, cap_);
    memory_.pop_front();
  }
}

const EventRecord* PendingEvents::front() {
  while (!files_.empty()) {
    if (loaded_) return &*loaded_;
    const std::string path = files_.front();
    std::ifstream in(path, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    try {
      if (!in) throw InputError(fmt::format("{}: cannot read", path));
      loaded_ = record_from_cbor(ss.str(), path);
      return &*loaded_;
    } catch (const std::exception& e) {
      std::error_code ec;
      fs::rename(path, path + ".bad", ec);
      spdlog::error("{} (moved aside as {}.bad)", e.what(), path);
      files_.pop_front();
    }
  }
  return memory_.empty() ? nullptr : &memory_.front();
}

void PendingEvents::pop() {
  if (!files_.empty()) {
    std::error_code ec;
    fs::remove(files_.front(), ec);
    if (ec)
      spdlog::error("{}: cannot remove the committed spill file: {}", files_.front(), ec.message());
    files_.pop_front();
    loaded_.reset();
    return;
  }
  if (!memory_.empty()) memory_.pop_front();
}

void PendingEvents::spill_excess() {
  while (memory_.size() > hold_ && spill(memory_.front())) memory_.pop_front();
}

void PendingEvents::spill_all() {
  while (!memory_.empty() && spill(memory_.front())) memory_.pop_front();
}

}  // namespace brakefit::daemon
