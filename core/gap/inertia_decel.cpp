// A wheel's inertia on a roller at 2-6 km/h: its force, I a / R^2, is in the few samples where
// the wheel decelerates, where the curve passes its peak and the wheel starts to run away (10-40
// of a run's hundreds). Over all samples its held-out gain is diluted below the gate while the
// fit places it within a few per cent (a car's 2.15 kg m^2 fitted 2.14, held-out gain -0.008).
// Held out over the decelerating samples alone, a wheel's inertia takes 35-80 % of the error
// there; generator B's every-export null sets, whose curves bend there too, at most 29 %.
#include <fmt/format.h>

#include <cmath>

#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// A sample counts where the wheel decelerates faster than this (a quasi-static roller wheel
/// decelerates by its slip's rise alone: 0.05 m/s^2 on a 10 s ramp at 5 km/h).
constexpr double kDecelMinMps2 = 0.5;
/// Fewer decelerating samples than this say nothing held out (one run's two last samples).
constexpr std::size_t kDecelMinPoints = 10;

struct HeldOut {
  double rms_n = NAN;
  std::size_t points = 0;
};

/// Held-out RMS over the decelerating samples (leave one run out, blocks past kMaxFolds).
HeldOut heldout_decelerating(const std::vector<Run>& runs, const std::vector<Effect>& effects,
                             const Fitter& fit) {
  double sq = 0;
  std::size_t points = 0;
  const std::size_t n = runs.size(), folds = std::min(n, kMaxFolds);
  for (std::size_t k = 0; k < folds; ++k) {
    std::size_t lo = 0, hi = 0;
    const std::vector<double> params = fit(fold_training(runs, k, lo, hi), effects).params;
    for (std::size_t j = lo; j < hi; ++j) {
      const Run& r = runs[j];
      if (r.wheel_accel_mps2.size() != r.t_s.size()) continue;
      const std::vector<double> f = predict(r, params, effects);
      for (std::size_t i = 0; i < f.size(); ++i)
        if (-r.wheel_accel_mps2[i] > kDecelMinMps2 && r.fitted_at(i)) {
          sq += (f[i] - r.force_n[i]) * (f[i] - r.force_n[i]);
          ++points;
        }
    }
  }
  return {points ? std::sqrt(sq / static_cast<double>(points)) : NAN, points};
}

}  // namespace

std::optional<DecelGain> gain_where_decelerating(const std::vector<Run>& runs,
                                                 const std::vector<Effect>& current,
                                                 const std::vector<Effect>& model,
                                                 const Fitter& fit) {
  for (const Run& r : runs)
    if (r.bench != can::BenchKind::Roller) return std::nullopt;
  const HeldOut before = heldout_decelerating(runs, current, fit);
  if (before.points < kDecelMinPoints || !(before.rms_n > 0)) return std::nullopt;
  const double after_n = heldout_decelerating(runs, model, fit).rms_n;
  return DecelGain{1.0 - after_n / before.rms_n, before.rms_n, after_n, before.points};
}

std::optional<std::string> inertia_in_deceleration(const std::vector<Run>& runs,
                                                   const std::vector<Effect>& current,
                                                   const std::vector<Effect>& model,
                                                   const EffectScore& s, const Fitter& fit) {
  if (s.effect != Effect::WheelInertia || s.params.empty() || !(s.params.front().second > 0))
    return std::nullopt;
  const auto g = gain_where_decelerating(runs, current, model, fit);
  if (!g || !(g->gain >= kInertiaDecelGain)) return std::nullopt;
  return fmt::format(
      "where the wheel decelerates (past {:.1f} m/s^2: {} samples, where its inertial force "
      "lies), held out, the inertia takes {:.0f} % of the error ({:.1f} N to {:.1f} N; at least "
      "{:.0f} %)",
      kDecelMinMps2, g->points, 100 * g->gain, g->before_n, g->after_n, 100 * kInertiaDecelGain);
}

}  // namespace brakefit::gap
