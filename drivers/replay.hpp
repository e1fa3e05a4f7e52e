#pragma once
// Sources built from the drivers: a candump log replayed in real time (or faster) or as fast as
// possible, and the local live source (GPIO encoders + Modbus RTU pressure into one queue).
#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "drivers/gpio.hpp"
#include "drivers/modbus_rtu.hpp"
#include "drivers/source.hpp"

namespace brakefit::drivers {

class ReplaySource final : public FrameSource {
 public:
  /// speed: 1.0 real time, 2.0 twice as fast; 0 as fast as possible. Throws InputError naming the
  /// file and line for a malformed log.
  /// loop: start again at the end, time stamps shifted past the last one plus a second (soak
  /// benches: hours of data from one log); never finished.
  ReplaySource(const std::string& path, double speed, bool loop = false);
  std::optional<can::LoggedFrame> next(int timeout_ms) override;
  bool finished() const override { return !loop_ && pos_ >= frames_.size(); }
  static constexpr std::chrono::milliseconds kCoalesce{1};
  std::string describe() const override { return "replay " + path_; }

 private:
  std::string path_;
  double speed_;
  bool loop_;
  std::vector<can::LoggedFrame> frames_;
  std::size_t pos_ = 0;
  std::int64_t shift_us_ = 0;  ///< added to every stamp of the current pass
  std::chrono::steady_clock::time_point t0_;
};

class LocalLiveSource final : public FrameSource {
 public:
  /// Opens the pressure transducer first, then the GPIO lines (open_edges), so an absent serial
  /// port and an absent gpiochip are both named whichever is missing.
  LocalLiveSource(const GpioConfig& g, const ModbusRtuConfig& r,
                  const std::function<std::unique_ptr<EdgeSource>(const GpioConfig&)>& open_edges);
  std::optional<can::LoggedFrame> next(int timeout_ms) override { return q_.pop(timeout_ms); }
  std::string describe() const override { return describe_; }

 private:
  std::string describe_;  ///< built once: describe() is asked for every status and event
  GpioConfig gcfg_;
  ModbusRtuConfig rcfg_;
  FrameQueue q_;
  LiveClock clock_;
  std::unique_ptr<ModbusRtuPressureReader> rtu_;
  std::unique_ptr<GpioEncoderReader> gpio_;
};

/// Writes every frame of a live session as a candump log in dir (brakefit-<unix s>.log), starting a
/// new file past max_bytes or max_age_s, keeping at most keep_files.
class CandumpRecorder {
 public:
  CandumpRecorder(std::string dir, std::uint64_t max_bytes, double max_age_s, int keep_files);
  ~CandumpRecorder();
  CandumpRecorder(const CandumpRecorder&) = delete;
  CandumpRecorder& operator=(const CandumpRecorder&) = delete;
  /// false when writing failed (disk full): the caller raises a status flag.
  bool write(const can::LoggedFrame& f);
  void flush();
  const std::string& current_path() const { return path_; }
  std::uint64_t rotations() const { return rotations_; }

 private:
  void open(std::int64_t t_us);
  std::string dir_;
  std::uint64_t max_bytes_;
  std::int64_t max_age_us_;
  int keep_files_;
  std::FILE* f_ = nullptr;
  std::string path_;
  std::uint64_t bytes_ = 0, rotations_ = 0;
  std::int64_t opened_us_ = 0;
  int seq_ = 0;
};

}  // namespace brakefit::drivers
