// How far a model's parameters move between the runs: the model refitted with each held-out
// fold left out (the folds of heldout), the spread of those fits as a delete-a-group jackknife
// standard error. A fit's own covariance assumes independent residuals and the right model; the
// runs disagree more than that (a wheel inertia of 0.75 kg m^2 with a formal error of 0.012,
// whose folds gave 0.67-1.07), and that disagreement is what a magnitude carried to other
// events has to allow for.
#include <algorithm>
#include <cmath>

#include "core/gap/internal.hpp"

namespace brakefit::gap {

std::vector<double> fold_spread(const std::vector<Run>& runs, const std::vector<Effect>& effects,
                                const Fitter& fit) {
  const std::size_t n = runs.size(), folds = std::min(n, kMaxFolds);
  if (folds < kMinSpreadFolds) return {};
  std::vector<std::vector<double>> fitted;
  for (std::size_t k = 0; k < folds; ++k) {
    std::size_t lo = 0, hi = 0;
    fitted.push_back(fit(fold_training(runs, k, lo, hi), effects).params);
  }
  const auto g = static_cast<double>(folds);
  std::vector<double> se(fitted.front().size(), 0.0);
  for (std::size_t j = 0; j < se.size(); ++j) {
    double mean = 0.0, ss = 0.0;
    for (const auto& f : fitted) mean += f[j] / g;
    for (const auto& f : fitted) ss += (f[j] - mean) * (f[j] - mean);
    se[j] = std::sqrt((g - 1.0) / g * ss);
  }
  return se;
}

}  // namespace brakefit::gap
