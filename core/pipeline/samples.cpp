#include "core/pipeline/samples.hpp"

#include <algorithm>

namespace brakefit::pipeline {

double EncoderSpeed::update(const can::EncoderMsg& m, std::int64_t t_ns) {
  if (!init_) {
    init_ = true;
    last_count_ = m.count_x4_mod;
    last_edge_us_ = seen_edge_us_ = m.edge_time_us;
    last_edge_frame_ns_ = seen_edge_frame_ns_ = t_ns;
    return speed_;
  }
  // The frame in which this message's last edge first came (frames without a new edge repeat it).
  if (m.edge_time_us != seen_edge_us_) {
    seen_edge_us_ = m.edge_time_us;
    seen_edge_frame_ns_ = t_ns;
  }
  // Differences modulo 2^24 (count) and 2^32 (edge time), as signed values.
  auto dcount = static_cast<std::int32_t>((m.count_x4_mod - last_count_) & 0xFFFFFFu);
  if (dcount & 0x800000) dcount -= 0x1000000;
  const auto dedge_us =
      static_cast<std::int64_t>(static_cast<std::int32_t>(m.edge_time_us - last_edge_us_));
  if (dcount != 0 && dedge_us > 0 && dedge_us < kMinSpanUs) {
    if (seen_edge_frame_ns_ == t_ns) {
      // Edges closer together than a frame can resolve (a frame 0.4 ms after the last one read
      // 183 m/s from one count over 2.6 us): hold the speed; the next frame spans both.
      ++short_spans_;
      return speed_;
    }
    // No edge has come since that short span: the wheel stopped right after it (a locking
    // wheel; held, its speed read 6 m/s for ever and the lock was never seen). Take the counts
    // and let the speed fall as without edges since the frame that brought them.
    last_count_ = m.count_x4_mod;
    last_edge_us_ = m.edge_time_us;
    last_edge_frame_ns_ = seen_edge_frame_ns_;
    dcount = 0;
  }
  if (dcount != 0 && dedge_us > 0) {
    speed_ = static_cast<double>(dcount) * m_per_count_ / (static_cast<double>(dedge_us) * 1e-6);
    last_count_ = m.count_x4_mod;
    last_edge_us_ = m.edge_time_us;
    last_edge_frame_ns_ = t_ns;
  } else if (dcount != 0) {
    // Counts moved but the edge clock did not advance: the sender restarted its clock (or the
    // log was joined). Without this the speed would read 0 until the clock caught up (up to
    // 2^32 us, 71 minutes). Start again from this frame; the speed holds meanwhile.
    ++resyncs_;
    last_count_ = m.count_x4_mod;
    last_edge_us_ = m.edge_time_us;
    last_edge_frame_ns_ = t_ns;
  } else {
    // No new edge: the speed is at most one count over the time since the last edge.
    const double since_s = static_cast<double>(t_ns - last_edge_frame_ns_) * 1e-9;
    if (since_s > 0.2)
      speed_ = 0.0;
    else if (since_s > 0)
      speed_ = std::copysign(std::min(std::abs(speed_), m_per_count_ / since_s), speed_);
  }
  return speed_;
}

SampleBuilder::SampleBuilder(const Calibration& c)
    : cal_(c),
      ref_(c.bench == can::BenchKind::Roller ? c.roller_ppr : c.fifth_wheel_ppr,
           c.bench == can::BenchKind::Roller ? c.roller_radius_m : c.fifth_wheel_radius_m),
      wheel_(c.wheel_ppr, c.wheel_radius_m) {}

std::optional<Sample> SampleBuilder::take_pending() {
  if (!pending_) return std::nullopt;
  pending_ = false;
  if (!have_ref_ || !have_pressure_) return std::nullopt;
  Sample s = cur_;
  s.t_ns = std::max(pending_t_ns_, last_t_ns_ + 1);  // strictly monotonic even if the log is not
  last_t_ns_ = s.t_ns;
  ++stats_.samples;
  return s;
}

std::optional<Sample> SampleBuilder::flush() {
  return take_pending();
}

std::optional<Sample> SampleBuilder::feed(const can::LoggedFrame& f) {
  ++stats_.frames;
  const std::int64_t t_ns = f.t_us * 1000;
  std::optional<Sample> out;
  if (pending_ && t_ns > pending_t_ns_ + kGroupWindowNs) out = take_pending();
  const auto msg = can::decode(f.frame);
  if (!msg) {
    ++stats_.unknown_ids;
    return out;
  }
  if (f.frame.len < can::message(f.frame.id).dlc) {
    ++stats_.short_frames;  // cut mid-frame (a log truncated at a byte boundary): not decoded
    return out;
  }
  if (const auto* e = std::get_if<can::EncoderMsg>(&*msg)) {
    const bool is_ref = cal_.bench == can::BenchKind::Roller
                            ? e->channel == can::Channel::Roller
                            : e->channel == can::Channel::FifthWheel;
    if (is_ref) {
      cur_.v_ref_mps = ref_.update(*e, t_ns);
      have_ref_ = true;
      stats_.encoder_resyncs = ref_.resyncs() + wheel_.resyncs();
    } else if (e->channel == can::Channel::Wheel) {
      if (last_wheel_counter_ >= 0 &&
          e->counter != static_cast<std::uint8_t>(last_wheel_counter_ + 1))
        ++stats_.counter_gaps;
      last_wheel_counter_ = e->counter;
      if (pending_) out = take_pending();  // the previous cycle is complete
      cur_.v_wheel_mps = wheel_.update(*e, t_ns);
      stats_.encoder_resyncs = ref_.resyncs() + wheel_.resyncs();
      pending_ = true;
      pending_t_ns_ = t_ns;
    }
  } else if (const auto* p = std::get_if<can::PressureMsg>(&*msg)) {
    cur_.pressure_bar = p->pressure_bar;
    cur_.sensor_fault = p->status != 0;
    have_pressure_ = true;
  } else if (const auto* fm = std::get_if<can::TesterForceMsg>(&*msg)) {
    cur_.force_n = fm->brake_force_n;
  } else if (const auto* s = std::get_if<can::TestStateMsg>(&*msg)) {
    cur_.state = s->state;
  } else if (const auto* ef = std::get_if<can::EncoderFaultsMsg>(&*msg)) {
    // Cumulative modulo 2^24 at the sender: the growth since the last report counts. The first
    // report only sets the reference (a recording may start long after the reader did).
    if (last_faults_) {
      const auto grow = [](std::uint32_t now, std::uint32_t before) {
        return static_cast<std::size_t>((now - before) & 0xFFFFFFu);
      };
      stats_.encoder_faults +=
          grow(ef->lost_edges_mod, last_faults_->lost_edges_mod) +
          grow(ef->illegal_transitions_mod, last_faults_->illegal_transitions_mod);
    }
    last_faults_ = *ef;
    cur_.encoder_faults = stats_.encoder_faults;
  }
  return out;
}

}  // namespace brakefit::pipeline
