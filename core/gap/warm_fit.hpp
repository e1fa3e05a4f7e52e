#pragma once
// The diagnosis's fitter: every fit of a model to some runs starts from the baseline's curve, from
// a neutral one and, where the baseline is flat-topped (E > 0.5), from the baseline's curve with E
// at 0; where the same runs were fitted with the model less its last effect and that model names
// an effect, from that fit too (the effects already named at their values, the new one at its
// start). Forward selection adds one effect at a time; started cold, the effects named before it
// restart from their catalogue starts and can stop in a worse minimum than the model without the
// new effect (load transfer after relaxation and inertia on a ground set: in-sample BIC +385). A
// fit of some of the runs that ends well above the same model's fit of more runs restarts from
// that fit: two of three runs alone can lead every start to a minimum the three runs avoid. Speed
// friction fitted to its range's end is refitted from inside the range.
#include <map>
#include <optional>
#include <tuple>
#include <vector>

#include "core/gap/gap.hpp"

namespace brakefit::gap {

/// Fits from an explicit start: B, C, D, E and the first effects' parameters (param_names'
/// order), each kept inside this model's range; the parameters past x0_head at their starts.
Fit fit_runs_from(const std::vector<const Run*>& runs, const std::vector<Effect>& effects,
                  const std::vector<double>& x0_head);

class WarmFitter {
 public:
  WarmFitter(const MfParams& baseline, const MfParams& neutral)
      : baseline_(baseline), neutral_(neutral) {}
  /// The fit with the lowest SSR over the two (three) starts.
  Fit operator()(const std::vector<const Run*>& runs, const std::vector<Effect>& effects);

 private:
  /// The runs by content (size, first time, sums of slip and force), not by address: the same
  /// runs rebuilt elsewhere are the same runs, other runs at a reused address are not.
  using RunsKey = std::vector<std::tuple<std::size_t, double, double, double>>;
  static RunsKey key_of(const std::vector<const Run*>& runs);
  /// Where speed friction, the model's last effect, ends on its range's end: the best fit with it
  /// inside, if any.
  std::optional<Fit> speed_friction_inside(const std::vector<const Run*>& runs,
                                           const std::vector<Effect>& effects, const Fit& best,
                                           const RunsKey& key) const;
  MfParams baseline_, neutral_;
  std::map<std::pair<RunsKey, std::vector<Effect>>, std::vector<double>> fitted_;
  /// Per model, its fit over the most points so far and that fit's mean square.
  struct Widest {
    std::size_t points = 0;
    double mean_square = 0;
    std::vector<double> params;
  };
  std::map<std::vector<Effect>, Widest> widest_;
};

}  // namespace brakefit::gap
