// The held-out error every candidate is ranked by, and the folds it is measured over.
#include <algorithm>
#include <cmath>

#include "core/gap/internal.hpp"

namespace brakefit::gap {

/// Held-out error: RMS over runs of each run's RMSE with parameters fitted on runs outside its
/// fold. Up to kMaxFolds runs each run is its own fold (leave one run out); past that the runs
/// are cut into kMaxFolds blocks of consecutive runs (a block of a day's tests held out at once),
/// so a set's cost grows with its points, not with their square.
std::vector<const Run*> fold_training(const std::vector<Run>& runs, std::size_t k, std::size_t& lo,
                                      std::size_t& hi) {
  const std::size_t n = runs.size(), folds = std::min(n, kMaxFolds);
  lo = k * n / folds;
  hi = (k + 1) * n / folds;
  std::vector<const Run*> train;
  for (std::size_t i = 0; i < n; ++i)
    if (i < lo || i >= hi) train.push_back(&runs[i]);
  return train;
}

namespace {

/// Two runs held out in blocks: each run's kTwoRunBlocks blocks of consecutive points, one at a
/// time, its run's other blocks and the other run fitted. One run alone cannot place what only
/// the two runs' different ramps separate (a time offset's force is a ramp's rate times the
/// offset, on one ramp the curve's own shift): of a car's two runs at 2.1 km/h with a 16 ms
/// offset, the offset fitted on either run alone predicted the other 95 % worse than no offset.
/// The run's history (lags, filters) is still predicted through its held-out block.
double heldout_two_runs(const std::vector<Run>& runs, const std::vector<Effect>& effects,
                        const Fitter& fit) {
  double sq_runs = 0;
  for (std::size_t k = 0; k < 2; ++k) {
    const Run& other = runs[1 - k];
    Run masked = runs[k];
    const std::size_t n = masked.t_s.size();
    double sq = 0;
    for (std::size_t b = 0; b < kTwoRunBlocks; ++b) {
      const std::size_t lo = b * n / kTwoRunBlocks, hi = (b + 1) * n / kTwoRunBlocks;
      masked.fit_mask.assign(n, 1);
      std::fill(masked.fit_mask.begin() + static_cast<std::ptrdiff_t>(lo),
                masked.fit_mask.begin() + static_cast<std::ptrdiff_t>(hi), 0);
      const std::vector<double> params = fit({&masked, &other}, effects).params;
      const std::vector<double> f = predict(runs[k], params, effects);
      for (std::size_t i = lo; i < hi; ++i)
        sq += (f[i] - runs[k].force_n[i]) * (f[i] - runs[k].force_n[i]);
    }
    sq_runs += sq / static_cast<double>(std::max<std::size_t>(n, 1));
  }
  return std::sqrt(sq_runs / 2.0);
}

}  // namespace

double heldout(const std::vector<Run>& runs, const std::vector<Effect>& effects,
               const Fitter& fit) {
  if (runs.size() == 2) return heldout_two_runs(runs, effects, fit);
  const std::size_t n = runs.size(), folds = std::min(n, kMaxFolds);
  double sq = 0;
  for (std::size_t k = 0; k < folds; ++k) {
    std::size_t lo = 0, hi = 0;
    const std::vector<double> params = fit(fold_training(runs, k, lo, hi), effects).params;
    for (std::size_t i = lo; i < hi; ++i) {
      const double e = rmse(runs[i], params, effects);
      sq += e * e;
    }
  }
  return std::sqrt(sq / static_cast<double>(n));
}

}  // namespace brakefit::gap
