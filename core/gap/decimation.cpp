// Decimation: a conditioned run cut to a budget of points, and the budget a set of runs gets.
#include <algorithm>
#include <utility>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

Run decimate(Run full, std::size_t max_points) {
  // Uniform in time. (Uniform in slip progress over-weights the runaway after the peak, where
  // slip is measured across only one or two frames: a null case's gap was 147 N instead of 7 N.)
  const std::size_t n = full.t_s.size();
  if (n <= max_points || max_points < 2) return full;
  std::vector<std::size_t> idx;
  for (std::size_t k = 0; k < max_points; ++k) idx.push_back(k * (n - 1) / (max_points - 1));
  // Every per-sample series a run has at conditioning; the ones filled later (the slip as
  // conditioned, the fit mask) are still empty here.
  auto pick = [&idx](std::vector<double>& v) {
    std::vector<double> kept;
    kept.reserve(idx.size());
    for (std::size_t i : idx) kept.push_back(v[i]);
    v = std::move(kept);
  };
  for (std::vector<double>* v :
       {&full.t_s, &full.slip, &full.slip_sd, &full.v_ref_mps, &full.force_n,
        &full.wheel_accel_mps2, &full.wheel_angle_rad, &full.ref_angle_rad, &full.ref_decel_mps2,
        &full.pressure_rate_bar_per_s, &full.encoder_wave[0].cos, &full.encoder_wave[0].sin,
        &full.encoder_wave[1].cos, &full.encoder_wave[1].sin})
    pick(*v);
  return full;
}

std::size_t points_per_run(std::size_t n_runs) {
  constexpr std::size_t kPerRun = ConditionOptions{}.max_points, kBudget = 2400, kFloor = 120;
  if (n_runs == 0) return kPerRun;
  return std::clamp(kBudget / n_runs, kFloor, kPerRun);
}

double relative_cost(std::size_t n_runs) {
  const double points = static_cast<double>(n_runs * points_per_run(n_runs));
  const double folds =
      static_cast<double>(n_runs == 2 ? 2 * kTwoRunBlocks : std::min(n_runs, kMaxFolds));
  return points * folds / (3.0 * ConditionOptions{}.max_points * 3.0);
}

}  // namespace brakefit::gap
