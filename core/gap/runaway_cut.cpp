// Where a run ends: at the wheel's lock-up runaway (a slip jump that stays) or at a locked wheel.
#include <algorithm>
#include <cstddef>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

/// Past this slip the wheel is taken as locked.
constexpr double kLockSlip = 0.9;
/// A lock-up runaway starts past the linear region: jumps below this slip are noise. (2 %: a
/// wheel capped by the cradle below its peak runs away from there.)
constexpr double kRunawayMinSlip = 0.02;
/// A runaway's jump stays: this many samples after it are all above the slip before it.
constexpr std::size_t kRunawayHoldSamples = 2;
/// Through a runaway the tyre's force falls from its peak (C's MF 6.1 tyres: 20-30 % by the lock)
/// while a brake's line pressure or a wheel's inertial force rises: a channel that stays within
/// 2 % of the force before the jump and ends 5 % under it shows the tyre.
constexpr double kRunawayTyreRiseRatio = 1.02, kRunawayTyreFallRatio = 0.95;

std::size_t runaway_cut(Run& full, const std::vector<double>& v_wheel, can::BenchKind bench,
                        const ConditionOptions& o) {
  // A jump per sample is a slip rate only at one sample rate: on the roller at 100 Hz a 0.01
  // jump is a wheel at 5 km/h losing 1.4 m/s^2, still rolling on its curve, and the heavy
  // wheel's inertial force (I a / R^2), kept at 500 Hz up to 7 m/s^2, would be cut with it. On
  // the ground the same slip rate is a deceleration 5-65 times as large, and the jump per sample
  // stays (the runaway is read through the channel as well), but for a run it would leave too
  // short to diagnose: at 50 Hz a truck's air brake ramps its slip by 0.012 a sample in the
  // linear region (0.6 /s at 57 km/h), and a jump of 0.01 cut such a run to two samples.
  const double per_sample = o.runaway_slip_per_sample;
  const double interval_s = median_interval_s(full.t_s);
  auto slip_at = [&](std::size_t k) { return 1.0 - v_wheel[k] / full.v_ref_mps[k]; };
  auto stays_up = [&](std::size_t i, double level) {
    for (std::size_t k = i + 1; k < std::min(v_wheel.size(), i + 1 + kRunawayHoldSamples); ++k)
      if (slip_at(k) <= level) return false;
    return true;
  };
  // A channel that falls through the runaway shows the tyre (a brake's line pressure rises on
  // with the pedal while the wheel locks; a wheel's inertial force in the channel, I a / R^2,
  // rises too): on the ground its runaway is the tyre's curve past the peak, kept up to the lock.
  auto falls_through = [&](std::size_t i) {
    if (bench != can::BenchKind::Ground) return false;
    std::size_t j = i;
    while (j < v_wheel.size() && slip_at(j) < kLockSlip) ++j;
    if (j < i + kRunawayHoldSamples + 1) return false;
    const double before = full.force_n[i - 1];
    const double top = *std::max_element(full.force_n.begin() + static_cast<std::ptrdiff_t>(i),
                                         full.force_n.begin() + static_cast<std::ptrdiff_t>(j));
    return before > 0 && top <= kRunawayTyreRiseRatio * before &&
           full.force_n[j - 1] < kRunawayTyreFallRatio * before;
  };
  // The lock-up runaway: past the peak a wheel can lose speed within one or two frames. There the
  // slip is measured across a single frame and the force is dominated by the wheel's deceleration
  // (I a / R^2, a numerical derivative of a step): not quasi-static data. The run is cut where
  // the slip first jumps by more than runaway_slip_per_sample between two samples and stays up
  // (the next kRunawayHoldSamples samples above the level before the jump by that much): a light
  // wheel on a long relaxation length at 2-3 km/h oscillates by +-4 % slip at 25 Hz, and each
  // upswing of that is a jump that falls back, not a lock-up.
  // A locked wheel is cut as well: the rim is held by the brake, I w' = F R - Tb no longer holds.
  auto cut_at = [&](double runaway_slip_per_sample) -> std::size_t {
    full.runaway = false;
    bool kept_runaway = false;
    for (std::size_t i = 1; i < v_wheel.size(); ++i) {
      const double s0 = slip_at(i - 1);
      const double s1 = slip_at(i);
      bool runaway = !kept_runaway && runaway_slip_per_sample > 0 && s0 > kRunawayMinSlip &&
                     s1 - s0 > runaway_slip_per_sample && stays_up(i, s0 + runaway_slip_per_sample);
      if (runaway && falls_through(i)) {
        kept_runaway = true;
        runaway = false;
      }
      if (runaway || s1 >= kLockSlip) {
        full.runaway = runaway;
        full.runaway_force_n = full.force_n[i - 1];
        return i;
      }
    }
    return full.t_s.size();
  };
  if (bench == can::BenchKind::Roller)
    return cut_at(per_sample > 0 ? std::max(per_sample, o.runaway_slip_per_s * interval_s) : 0.0);
  const std::size_t keep = cut_at(per_sample);
  if (keep >= kMinRunSamples || per_sample <= 0 || o.ground_runaway_slip_per_s <= 0) return keep;
  return cut_at(std::max(per_sample, o.ground_runaway_slip_per_s * interval_s));
}

}  // namespace brakefit::gap
