#include "core/gap/warm_fit.hpp"

#include <algorithm>
#include <array>
#include <optional>

#include "core/gap/internal.hpp"

namespace brakefit::gap {

WarmFitter::RunsKey WarmFitter::key_of(const std::vector<const Run*>& runs) {
  RunsKey key;
  key.reserve(runs.size());
  // Over the samples a fit takes: a run with a block held out is other runs.
  for (const Run* r : runs) {
    double slip = 0, force = 0;
    for (std::size_t i = 0; i < r->t_s.size(); ++i)
      if (r->fitted_at(i)) {
        slip += r->slip[i];
        force += r->force_n[i];
      }
    key.emplace_back(r->fitted_points(), r->t_s.empty() ? 0.0 : r->t_s.front(), slip, force);
  }
  return key;
}

namespace {

/// A baseline with E above this is flat-topped: an additive force that rises on past the tyre's
/// peak bends the baseline that way (a car tyre's E at its peak lies near 0; a truck's is
/// negative).
constexpr double kFlatTopE = 0.5;

/// A fit of some runs restarts from the same model's fit of more runs when its mean square is
/// more than this times that fit's (runs of one set differ in their noise by far less).
constexpr double kRestartMeanSquareRatio = 1.5;

/// Where speed friction ends on its range's end: its starts, as shares of the range (0-20).
constexpr std::array<double, 3> kSpeedFrictionInsideStarts{0.03, 0.1, 0.3};

/// A start with the load following the body's pitch mode, a car's 1.25 Hz at damping 0.6 (lag
/// 2 zeta / w = 0.15 s), the curve the baseline's: the parameters up to the load transfer's (the
/// rest at their catalogue starts). None where a cradle cap comes first (its start is the runs').
std::optional<std::vector<double>> pitch_mode_start(const MfParams& curve,
                                                    const std::vector<Effect>& effects) {
  constexpr double kModeS2 = 0.0162, kLagS = 0.15;
  std::vector<double> x0{curve.B, curve.C, curve.D, curve.E};
  for (Effect e : effects) {
    if (e == Effect::CradleCap) return std::nullopt;
    for (const EffectParam& ep : effect_params(e)) x0.push_back(ep.start);
    if (is_load_transfer(e)) {
      x0[x0.size() - 2] = kLagS;
      x0.back() = kModeS2;
      return x0;
    }
  }
  return std::nullopt;
}

}  // namespace

std::optional<Fit> WarmFitter::speed_friction_inside(const std::vector<const Run*>& runs,
                                                     const std::vector<Effect>& effects,
                                                     const Fit& best, const RunsKey& key) const {
  // Past a few, the friction's law (D / (1 + lambda k V / V0), B x the same) is no longer a
  // friction falling with speed: lambda k V / V0 >> 1 turns the curve into D V0 / (lambda k V)
  // times a sine of B lambda k^2 V / V0, a family of its own that can bend to a heavy tyre's
  // sharp peak. A fit that runs there to the range's end (20) is taken from the minimum inside
  // the range where one lies, started from the model less the friction at a spread of values (a
  // truck's 1.9 fitted 20 from every other start; from these, 1.84).
  if (effects.empty() || effects.back() != Effect::SpeedFriction ||
      !param_at_bound(effects, Effect::SpeedFriction, best))
    return std::nullopt;
  const std::vector<Effect> before(effects.begin(), effects.end() - 1);
  std::vector<double> head{baseline_.B, baseline_.C, baseline_.D, baseline_.E};
  for (Effect e : before)
    for (const EffectParam& ep : effect_params(e)) head.push_back(ep.start);
  if (const auto it = fitted_.find({key, before}); it != fitted_.end()) head = it->second;
  const double hi = effect_params(Effect::SpeedFriction)[0].hi;
  std::optional<Fit> inside;
  for (const double share : kSpeedFrictionInsideStarts) {
    std::vector<double> x0 = head;
    x0.push_back(share * hi);
    Fit f = fit_runs_from(runs, effects, x0);
    if (!param_at_bound(effects, Effect::SpeedFriction, f) && (!inside || f.ssr < inside->ssr))
      inside = std::move(f);
  }
  return inside;
}

Fit WarmFitter::operator()(const std::vector<const Run*>& runs,
                           const std::vector<Effect>& effects) {
  Fit best = fit_runs(runs, effects, baseline_);
  if (Fit b = fit_runs(runs, effects, neutral_); b.ssr < best.ssr) best = std::move(b);
  // The baseline's curve with its E at 0: an effect the baseline took into the curve's shape (a
  // heavy wheel's inertial force rising on past the tyre's peak drove its E to 0.94) leaves the
  // baseline's E in a basin of its own. B's ground, a 1.24 kg m^2 wheel: from the baseline and
  // the neutral curve the inertia came out 0.73-1.06 at E 0.95, 5.6 N a point; from this start,
  // 1.227 at E 0.10, 4.1 N on a 3.8 N floor.
  if (baseline_.E > kFlatTopE) {
    MfParams flat = baseline_;
    flat.E = 0.0;
    if (Fit f = fit_runs(runs, effects, flat); f.ssr < best.ssr) best = std::move(f);
  }
  // The body's pitch mode is a minimum of its own: from the catalogue's start (a first-order
  // lag) a fit of a 1-1.5 Hz mode can stop at a short lag and a stiffness ratio far from a tyre's.
  if (const auto x0 = pitch_mode_start(baseline_, effects))
    if (Fit m = fit_runs_from(runs, effects, *x0); m.ssr < best.ssr) best = std::move(m);
  RunsKey key = key_of(runs);
  // A third start once an effect is named (the nuisance terms alone are the baseline's start).
  if (!effects.empty()) {
    const std::vector<Effect> before(effects.begin(), effects.end() - 1);
    const bool named =
        std::any_of(before.begin(), before.end(), [](Effect e) { return !is_nuisance(e); });
    if (const auto it = fitted_.find({key, before}); named && it != fitted_.end())
      if (Fit w = fit_runs_from(runs, effects, it->second); w.ssr < best.ssr) best = std::move(w);
  }
  // Where every start above ended far above the same model's fit of more runs, that fit is a
  // start too (B's ground, a 2.7 kg m^2 wheel: two of three runs went to E 0.96, 4 N in-sample
  // against 1.7 N, and the third run held out was 21 N off against 1.7 N).
  const auto mean_square = [](const Fit& f) {
    return f.points == 0 ? 0.0 : f.ssr / static_cast<double>(f.points);
  };
  Widest& w = widest_[effects];
  if (w.points > best.points && mean_square(best) > kRestartMeanSquareRatio * w.mean_square)
    if (Fit r = fit_runs_from(runs, effects, w.params); r.ssr < best.ssr) best = std::move(r);
  if (auto inside = speed_friction_inside(runs, effects, best, key)) best = std::move(*inside);
  if (best.points >= w.points) w = {best.points, mean_square(best), best.params};
  fitted_[{std::move(key), effects}] = best.params;
  return best;
}

}  // namespace brakefit::gap
