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

double heldout(const std::vector<Run>& runs, const std::vector<Effect>& effects,
               const Fitter& fit) {
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
