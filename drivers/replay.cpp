#include "drivers/replay.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <thread>

#include "core/can/candump.hpp"
#include "core/curve.hpp"
#include "drivers/candump_file.hpp"

namespace brakefit::drivers {

ReplaySource::ReplaySource(const std::string& path, double speed, bool loop)
    : path_(path), speed_(speed), loop_(loop), frames_(read_candump_file(path).frames) {
  t0_ = std::chrono::steady_clock::now();
}

std::optional<can::LoggedFrame> ReplaySource::next(int timeout_ms) {
  if (pos_ >= frames_.size() && loop_ && !frames_.empty()) {
    pos_ = 0;
    shift_us_ += frames_.back().t_us - frames_.front().t_us + 1'000'000;
  }
  if (pos_ >= frames_.size()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(timeout_ms));
    return std::nullopt;
  }
  if (speed_ > 0) {
    const double log_s =
        static_cast<double>(frames_[pos_].t_us + shift_us_ - frames_.front().t_us) * 1e-6;
    const auto due = t0_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                               std::chrono::duration<double>(log_s / speed_));
    const auto limit = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    if (due > limit) {
      std::this_thread::sleep_until(limit);
      return std::nullopt;
    }
    // Frames due within the next kCoalesce are handed over together after one sleep: at 1 kHz
    // per channel that halves the wake-ups; a frame is at most kCoalesce late (the pipeline uses
    // the frames' own timestamps, so results do not change).
    if (due > std::chrono::steady_clock::now()) std::this_thread::sleep_until(due + kCoalesce);
  }
  ++counters_.frames;
  can::LoggedFrame f = frames_[pos_++];
  f.t_us += shift_us_;
  return f;
}

LocalLiveSource::LocalLiveSource(
    const GpioConfig& g, const ModbusRtuConfig& r,
    const std::function<std::unique_ptr<EdgeSource>(const GpioConfig&)>& open_edges)
    : gcfg_(g), rcfg_(r) {
  rtu_ = std::make_unique<ModbusRtuPressureReader>(r, q_, counters_, clock_);
  gpio_ = std::make_unique<GpioEncoderReader>(g, open_edges(g), q_, counters_, clock_);
  describe_ = fmt::format("gpio {} ({} uAPI, {}) + modbus-rtu {}", gcfg_.chip,
                          gcfg_.uapi == GpioConfig::Uapi::V2 ? "v2" : "v1", gpio_->scheduling(),
                          rcfg_.device);
}

CandumpRecorder::CandumpRecorder(std::string dir, std::uint64_t max_bytes, double max_age_s,
                                 int keep_files)
    : dir_(std::move(dir)),
      max_bytes_(max_bytes),
      max_age_us_(static_cast<std::int64_t>(max_age_s * 1e6)),
      keep_files_(keep_files) {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec)
    throw InputError(fmt::format("{}: cannot create recording directory: {}", dir_, ec.message()));
}

CandumpRecorder::~CandumpRecorder() {
  if (f_) std::fclose(f_);
}

void CandumpRecorder::open(std::int64_t t_us) {
  if (f_) {
    std::fclose(f_);
    f_ = nullptr;
    ++rotations_;
  }
  path_ = fmt::format("{}/brakefit-{}-{:03}.log", dir_, t_us / 1'000'000, seq_++);
  f_ = std::fopen(path_.c_str(), "w");
  bytes_ = 0;
  opened_us_ = t_us;
  // Retention: keep the newest keep_files recordings.
  std::vector<std::filesystem::path> logs;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir_, ec))
    if (e.path().extension() == ".log" && e.path().filename().string().starts_with("brakefit-"))
      logs.push_back(e.path());
  std::sort(logs.begin(), logs.end(), [](const auto& a, const auto& b) {
    return std::filesystem::last_write_time(a) < std::filesystem::last_write_time(b) ||
           (std::filesystem::last_write_time(a) == std::filesystem::last_write_time(b) && a < b);
  });
  while (static_cast<int>(logs.size()) > keep_files_) {
    std::filesystem::remove(logs.front(), ec);
    logs.erase(logs.begin());
  }
}

bool CandumpRecorder::write(const can::LoggedFrame& fr) {
  if (!f_ || bytes_ >= max_bytes_ || fr.t_us - opened_us_ >= max_age_us_) open(fr.t_us);
  if (!f_) return false;
  const std::string line = can::format_candump_line(fr) + "\n";
  if (std::fwrite(line.data(), 1, line.size(), f_) != line.size()) return false;
  bytes_ += line.size();
  return true;
}

void CandumpRecorder::flush() {
  if (f_) std::fflush(f_);
}

}  // namespace brakefit::drivers
