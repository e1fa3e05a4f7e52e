#include "core/pipeline/events.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace brakefit::pipeline {

std::optional<Event> EventDetector::close(const std::string& reason, bool aborted) {
  Event e = std::move(*cur_);
  cur_.reset();
  recent_slip_.clear();
  armed_ = false;
  e.end_reason = reason;
  e.t_end_ns = e.samples.empty() ? e.t_start_ns : e.samples.back().t_ns;
  if (aborted) e.flags.push_back("aborted");
  const double dur_s = static_cast<double>(e.t_end_ns - e.t_start_ns) * 1e-9;
  if (e.samples.size() < set_.min_points || dur_s < set_.min_duration_s)
    e.flags.push_back("too_short");
  return e;
}

std::optional<std::string> implausible(const Sample& s, const EventSettings& set) {
  auto out = [](double v, double lo, double hi) { return !std::isfinite(v) || v < lo || v > hi; };
  if (out(s.v_ref_mps, set.min_speed_mps, set.max_speed_mps))
    return fmt::format("v_ref_mps {:g} outside [{:g}, {:g}]", s.v_ref_mps, set.min_speed_mps,
                       set.max_speed_mps);
  if (out(s.v_wheel_mps, set.min_speed_mps, set.max_speed_mps))
    return fmt::format("v_wheel_mps {:g} outside [{:g}, {:g}]", s.v_wheel_mps, set.min_speed_mps,
                       set.max_speed_mps);
  if (out(s.pressure_bar, set.min_pressure_bar, set.max_pressure_bar))
    return fmt::format("pressure_bar {:g} outside [{:g}, {:g}]", s.pressure_bar,
                       set.min_pressure_bar, set.max_pressure_bar);
  return std::nullopt;
}

std::optional<Event> EventDetector::feed(const Sample& s) {
  std::optional<Event> done;
  if (cur_ && static_cast<double>(s.t_ns - last_t_ns_) * 1e-9 > set_.sensor_timeout_s)
    done = close("sensor_timeout", true);
  last_t_ns_ = s.t_ns;
  if (const auto why = implausible(s, set_)) {
    // Never part of an event, never the lead-in: the event running ends here, flagged.
    if (!cur_ || done) return done;
    auto e = close("implausible_data", true);
    e->flags.push_back("implausible_data");
    e->note = fmt::format("{} at t = {:.6f} s", *why, static_cast<double>(s.t_ns) * 1e-9);
    return e;
  }
  if (cur_ && static_cast<double>(s.t_ns - cur_->t_start_ns) * 1e-9 > set_.max_event_s) {
    auto e = close("max_length", true);
    e->note = fmt::format("ran past max_event_s = {:g} s", set_.max_event_s);
    return e;
  }
  auto remember = [&] {
    const auto window_ns = static_cast<std::int64_t>(set_.lead_in_s * 1e9);
    before_.push_back(s);
    while (!before_.empty() && s.t_ns - before_.front().t_ns > window_ns) before_.pop_front();
  };
  if (!cur_ && !armed_) {
    if (s.pressure_bar < set_.release_pressure_bar) armed_ = true;
    remember();
    return done;
  }
  if (!cur_) {
    if (s.pressure_bar >= set_.start_pressure_bar && s.v_ref_mps >= set_.min_ref_speed_mps &&
        !done) {
      cur_ = Event{};
      cur_->lead_in.assign(before_.begin(), before_.end());
      before_.clear();
      cur_->event_id = next_id_++;
      cur_->bench = cal_.bench;
      cur_->t_start_ns = s.t_ns;
      cur_->encoder_faults_at_start = s.encoder_faults;
    } else {
      remember();
      return done;
    }
  }
  cur_->samples.push_back(s);
  if (s.sensor_fault &&
      std::find(cur_->flags.begin(), cur_->flags.end(), "sensor_fault") == cur_->flags.end())
    cur_->flags.push_back("sensor_fault");
  if (s.encoder_faults > cur_->encoder_faults_at_start &&
      std::find(cur_->flags.begin(), cur_->flags.end(), "edges_lost") == cur_->flags.end())
    cur_->flags.push_back("edges_lost");
  // The end decisions on the slip filtered over end_filter_s (the mean of those samples).
  recent_slip_.emplace_back(s.t_ns, slip_ratio(s));
  const auto window_ns = static_cast<std::int64_t>(set_.end_filter_s * 1e9);
  while (recent_slip_.size() > 1 && s.t_ns - recent_slip_.front().first > window_ns)
    recent_slip_.pop_front();
  double slip = 0;
  for (const auto& [t, k] : recent_slip_) slip += k;
  slip /= static_cast<double>(recent_slip_.size());
  if (s.v_ref_mps < set_.min_ref_speed_mps) return close("stopped", false);
  if (slip >= set_.lock_slip_ratio) return close("wheel_lock", false);
  if (cal_.bench == can::BenchKind::Roller &&
      (slip >= cal_.switch_off_slip_ratio || s.state == can::TestState::SwitchedOff))
    return close("switch_off_slip", false);
  if (s.state == can::TestState::Aborted) return close("tester_aborted", true);
  if (s.pressure_bar < set_.release_pressure_bar) return close("release", false);
  return done;
}

std::optional<Event> EventDetector::finish() {
  if (!cur_) return std::nullopt;
  return close("end_of_data", true);
}

std::optional<Event> EventDetector::finish_file() {
  if (!cur_) return std::nullopt;
  return close("end_of_file", false);
}

std::optional<Event> EventDetector::abort(const std::string& reason) {
  if (!cur_) return std::nullopt;
  return close(reason, true);
}

Curve event_curve(const Event& e, const Calibration& c, const EventSettings& s,
                  ForceSource source) {
  Curve curve;
  for (const Sample& smp : e.samples) {
    if (smp.v_ref_mps < s.min_ref_speed_mps) continue;
    const double force =
        source == ForceSource::Tester ? smp.force_n : c.brake_gain_n_per_bar * smp.pressure_bar;
    if (!std::isfinite(force)) continue;
    curve.slip_ratio.push_back(std::clamp(slip_ratio(smp), 0.0, 1.0));
    curve.force_n.push_back(force);
  }
  return curve;
}

}  // namespace brakefit::pipeline
