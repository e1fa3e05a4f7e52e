// The two-roller cradle's force cap, found from how the runs end (a light wheel runs away at the
// cap while its force still rises with slip).
#include <algorithm>
#include <cmath>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "core/gap/warm_fit.hpp"

namespace brakefit::gap {

/// The run up to its first sample whose slip (or force) is above the limit.
Run up_to(const Run& r, const std::vector<double>& x, double limit) {
  std::size_t n = 0;
  while (n < x.size() && x[n] <= limit) ++n;
  Run out = r;
  for (auto* v : {&out.t_s, &out.slip, &out.v_ref_mps, &out.force_n, &out.wheel_accel_mps2,
                  &out.ref_decel_mps2, &out.pressure_rate_bar_per_s, &out.slip_sd,
                  &out.wheel_angle_rad, &out.ref_angle_rad, &out.encoder_wave[0].cos,
                  &out.encoder_wave[0].sin, &out.encoder_wave[1].cos, &out.encoder_wave[1].sin})
    if (v->size() > n) v->resize(n);
  return out;
}

/// Least-squares slope of force over slip for the samples with force in [lo, hi].
static double force_slope(const Run& r, double lo_n, double hi_n) {
  double sk = 0, sf = 0, skk = 0, skf = 0, m = 0;
  for (std::size_t i = 0; i < r.slip.size(); ++i) {
    if (r.force_n[i] < lo_n || r.force_n[i] > hi_n) continue;
    sk += r.slip[i];
    sf += r.force_n[i];
    skk += r.slip[i] * r.slip[i];
    skf += r.slip[i] * r.force_n[i];
    ++m;
  }
  const double den = m * skk - sk * sk;
  return m >= 5 && den > 0 ? (m * skf - sk * sf) / den : NAN;
}

std::optional<CapEvidence> cradle_cap_evidence(const std::vector<Run>& runs) {
  if (runs.size() < 2) return std::nullopt;
  for (const Run& r : runs)
    if (r.bench != can::BenchKind::Roller) return std::nullopt;  // a cradle is a roller's
  double lo = INFINITY, hi = 0, sum = 0, ratio = INFINITY;
  for (const Run& r : runs) {
    if (!r.runaway) return std::nullopt;
    const double f = r.runaway_force_n;
    lo = std::min(lo, f);
    hi = std::max(hi, f);
    sum += f;
    const double initial = force_slope(r, 0.05 * f, 0.3 * f);
    const double end = force_slope(r, kCapKinkFrom * f, 1.0 * f);
    if (!(initial > 0) || !std::isfinite(end)) return std::nullopt;
    ratio = std::min(ratio, end / initial);
  }
  CapEvidence e;
  e.cap_n = sum / static_cast<double>(runs.size());
  e.spread = (hi - lo) / e.cap_n;
  e.end_slope_ratio = ratio;
  if (e.spread > kCapMaxSpread || e.end_slope_ratio < kCapMinEndSlopeRatio) return std::nullopt;
  return e;
}

bool cap_at_fitted_peak(CapEvidence& e, const std::vector<Run>& runs, const MfParams& start) {
  e.fitted_peak_ratio = fit_runs(pointers(runs), {}, start).params[2] / e.cap_n;
  // Fitted also from the wheel's rest, where the runs rested off zero slip beyond its
  // uncertainty: a slip offset (a wheel's radius off) shows at rest and moves the curve without
  // reshaping it, and fitted from zero a sharp peak's curve is bent off its own (a truck's runs
  // 0.8 % of slip off peaked past their runaway, and a cap was named beside the offset). A
  // relaxing tyre's bend does not show at rest: a cap behind it stays.
  if (const RestSlip rest = pooled_rest_slip(runs);
      rest.points > 0 && std::abs(rest.mean) > rest.uncertainty) {
    std::vector<Run> from_rest = runs;
    for (Run& r : from_rest)
      for (double& slip : r.slip) slip -= rest.mean;
    e.fitted_peak_ratio =
        std::min(e.fitted_peak_ratio, fit_runs(pointers(from_rest), {}, start).params[2] / e.cap_n);
  }
  return e.fitted_peak_ratio <= kCapAtPeakRatio;
}

double cap_kink_ratio(const std::vector<Run>& runs, double cap_n) {
  double ratio = INFINITY;
  for (const Run& r : runs) {
    const double initial = force_slope(r, 0.05 * cap_n, 0.3 * cap_n);
    const double end = force_slope(r, kCapKinkFrom * cap_n, kCapKinkTo * cap_n);
    if (!(initial > 0) || !std::isfinite(end)) return NAN;
    ratio = std::min(ratio, end / initial);
  }
  return runs.empty() ? NAN : ratio;
}

/// Least-squares rate of a run's force (N/s) over its last kEndRateS (at least three samples).
static double end_force_rate_n_per_s(const Run& r) {
  constexpr double kEndRateS = 0.05;
  double st = 0, sf = 0, stt = 0, stf = 0, m = 0;
  for (std::size_t k = r.t_s.size(); k-- > 0;) {
    if (m >= 3 && r.t_s.back() - r.t_s[k] > kEndRateS) break;
    const double t = r.t_s[k] - r.t_s.back();
    st += t;
    sf += r.force_n[k];
    stt += t * t;
    stf += t * r.force_n[k];
    ++m;
  }
  const double den = m * stt - st * st;
  return m >= 3 && den > 0 ? (m * stf - st * sf) / den : NAN;
}

/// Runs needed to read a cap behind a named lag.
constexpr std::size_t kCapBehindLagMinRuns = 3;

std::optional<CapEvidence> cap_behind_lag(const Report& rep, const std::vector<Run>& runs) {
  // Two runs' runaways meeting once each is moved by a fitted offset is one coincidence, not a
  // cap (a car's two runs at 2.1 km/h with a 16 ms offset, read at 9 ms, met within 1.8 %).
  if (runs.size() < kCapBehindLagMinRuns || std::isfinite(rep.cap_n)) return std::nullopt;
  // A channel dt late reads the force the tyre had dt before: each run's runaway at
  // F + dt dF/dt (a fast ramp's runaway reads lower than a slow one's). (Not behind a
  // relaxation: a relaxing tyre on a fast ramp runs away below its steady peak at one force in
  // every run, as at a cap, and the curve fitted with it peaks above that: generator C's roller
  // time offset of 97 ms, named a relaxation, and B's long relaxations were given caps; a
  // relaxation named beside a time offset too: a 0.33 m one at 4 km/h.)
  const auto dt_at = param_offset(rep.accepted, Effect::TimeOffset);
  if (!dt_at || param_offset(rep.accepted, Effect::RelaxationLength)) return std::nullopt;
  const double dt_s = rep.after.params.at(*dt_at);
  double lo = INFINITY, hi = 0, sum = 0;
  for (const Run& r : runs) {
    if (r.bench != can::BenchKind::Roller || !r.runaway) return std::nullopt;
    const double rate = end_force_rate_n_per_s(r);
    if (!std::isfinite(rate)) return std::nullopt;
    const double f = r.runaway_force_n + dt_s * rate;
    lo = std::min(lo, f);
    hi = std::max(hi, f);
    sum += f;
  }
  CapEvidence e;
  e.cap_n = sum / static_cast<double>(runs.size());
  e.spread = (hi - lo) / e.cap_n;
  e.end_slope_ratio = NAN;  // the lag bends the force's end over slip: not read
  e.fitted_peak_ratio = rep.after.params.at(2) / e.cap_n;
  if (!(e.spread <= kCapMaxSpread) || !(e.fitted_peak_ratio > kCapAtPeakRatio)) return std::nullopt;
  return e;
}

double cap_peak_beside_named(const Report& rep, const std::vector<Run>& runs) {
  // A threshold or a slip offset bends a sharp peak's curve fitted from zero slip off the tyre's
  // (a truck's 0.2 bar threshold: the curve without it peaked past the runaway); with them in,
  // the curve's peak is read again.
  if (!std::isfinite(rep.cap_n) || param_offset(rep.accepted, Effect::CradleCap) ||
      named_effects(rep.accepted).empty() || rep.after.params.size() != param_count(rep.accepted))
    return NAN;
  return fit_runs_from(pointers(runs), rep.accepted, rep.after.params).params[2] / rep.cap_n;
}

/// A cradle cap found on the runs (not fitted) goes first: its held-out gap before is the whole
/// runs' (gap_whole_n), after the gap below the cap (rep's baseline gap so far).
void put_cap_first(Report& rep, double cap_n, double gap_whole_n) {
  rep.cap_n = cap_n;
  EffectScore c;
  c.effect = Effect::CradleCap;
  c.params = {{"cap_n", cap_n}};
  c.heldout_rmse_before_n = gap_whole_n;
  c.heldout_rmse_after_n = rep.gap_before_rmse_n;
  c.gain = 1.0 - c.heldout_rmse_after_n / std::max(c.heldout_rmse_before_n, 1e-12);
  c.delta_bic = NAN;  // not a fitted model
  c.accepted = true;
  c.decision = "found from how the runs end (not fitted)";
  rep.effects.insert(rep.effects.begin(), c);
  if (rep.verdict == std::vector<std::string>{"none"}) rep.verdict.clear();
  rep.verdict.insert(rep.verdict.begin(), to_string(Effect::CradleCap));
  rep.gap_before_rmse_n = gap_whole_n;
}

}  // namespace brakefit::gap
