#pragma once
// Frames -> samples: decodes the bench frames, turns encoder counts and edge times into speeds
// (edge-to-edge timing, so quantisation stays small), holds the latest pressure, tester force and
// test state, and emits one sample per wheel-encoder frame, each with a monotonic t_ns.
#include <cmath>
#include <cstdint>
#include <optional>

#include "core/can/frame.hpp"
#include "core/can/layout.hpp"
#include "core/pipeline/calibration.hpp"

namespace brakefit::pipeline {

struct Sample {
  std::int64_t t_ns = 0;
  double v_ref_mps = 0.0;    ///< roller surface (roller bench) or fifth wheel (ground)
  double v_wheel_mps = 0.0;  ///< tested wheel circumferential speed
  double pressure_bar = 0.0;
  double force_n = NAN;  ///< the tester's own force reading, NaN when absent
  can::TestState state = can::TestState::Idle;
  bool sensor_fault = false;
  /// Edges the GPIO reader lost or saw in an illegal order since the stream began (from the
  /// ENCODER_FAULTS frames); an event during which it grows is flagged edges_lost.
  std::uint64_t encoder_faults = 0;
};

/// Speed from a quadrature encoder's x4 count (mod 2^24) and last-edge time (mod 2^32 us).
class EncoderSpeed {
 public:
  EncoderSpeed(double ppr, double radius_m) : m_per_count_(2.0 * M_PI * radius_m / (4.0 * ppr)) {}
  /// Updates with a frame received at t_ns; returns the speed in m/s.
  double update(const can::EncoderMsg& m, std::int64_t t_ns);
  double speed_mps() const { return speed_; }
  /// Times the sender's edge clock went backwards while counts moved (a bench controller that
  /// restarted): the new count and edge time became the reference.
  std::size_t resyncs() const { return resyncs_; }
  /// Frames whose last edge came less than kMinSpanUs after the previous one: not used alone.
  std::size_t short_spans() const { return short_spans_; }
  static constexpr std::int64_t kMinSpanUs = 200;

 private:
  double m_per_count_;
  std::size_t short_spans_ = 0;
  bool init_ = false;
  std::size_t resyncs_ = 0;
  std::uint32_t last_count_ = 0, last_edge_us_ = 0, seen_edge_us_ = 0;
  std::int64_t last_edge_frame_ns_ = 0, seen_edge_frame_ns_ = 0;
  double speed_ = 0.0;
};

struct SampleStats {
  std::size_t frames = 0;
  std::size_t unknown_ids = 0;  ///< counted and ignored
  std::size_t samples = 0;
  std::size_t counter_gaps = 0;     ///< lost frames detected by rolling counters
  std::size_t encoder_resyncs = 0;  ///< encoder edge clocks that restarted (EncoderSpeed::resyncs)
  std::size_t encoder_faults = 0;   ///< lost edges + illegal transitions the GPIO reader reported
  std::size_t short_frames = 0;     ///< layout ids with fewer data bytes than their DLC (a cut log)
};

/// A sample is emitted once its time group is complete: at the next wheel-encoder frame or at the
/// first frame more than kGroupWindowNs after the pending wheel frame, so pressure and force
/// frames of the same cycle are paired with that cycle's speeds whatever their order on the bus.
class SampleBuilder {
 public:
  static constexpr std::int64_t kGroupWindowNs = 500'000;
  explicit SampleBuilder(const Calibration& c);
  std::optional<Sample> feed(const can::LoggedFrame& f);
  /// The pending sample at the end of the data.
  std::optional<Sample> flush();
  const SampleStats& stats() const { return stats_; }

 private:
  Calibration cal_;
  EncoderSpeed ref_, wheel_;
  Sample cur_;
  std::optional<Sample> take_pending();
  bool have_ref_ = false, have_pressure_ = false, pending_ = false;
  std::int64_t pending_t_ns_ = 0;
  std::int64_t last_t_ns_ = INT64_MIN;
  int last_wheel_counter_ = -1;
  std::optional<can::EncoderFaultsMsg> last_faults_;
  SampleStats stats_;
};

}  // namespace brakefit::pipeline
