// An effect named before the effects after it, judged again beside them. Forward selection
// keeps what it named in each round: a relaxation length named first at a lag's place, with a
// wheel's inertia and a time offset named after it, holds a share of the time offset's lag that
// the two alone fit better held out. Where the model without such an effect leaves less held
// out, the effect only fitted what the later ones explain, and it is dropped.
#include <fmt/format.h>

#include <algorithm>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

std::optional<Needless> needless_effect(const std::vector<Run>& runs,
                                        const std::vector<Effect>& chosen, double current_heldout_n,
                                        const Fitter& fit) {
  const std::vector<Effect> names = named_effects(chosen);
  // Beside load transfer a model is judged in-sample (held out, its fold trades the tyre's shape
  // for the load), where a model without an effect never fits better.
  if (names.size() < 2 || std::any_of(names.begin(), names.end(), is_load_transfer))
    return std::nullopt;
  std::optional<Needless> best;
  for (const Effect e : names) {
    std::vector<Effect> model = chosen;
    model.erase(std::find(model.begin(), model.end(), e));
    const double without_n = heldout(runs, model, fit);
    if (!(without_n < (best ? best->heldout_n : current_heldout_n))) continue;
    best = Needless{e, std::move(model), {}, without_n, {}};
  }
  if (!best) return std::nullopt;
  best->fit = fit(pointers(runs), best->model);
  best->note = fmt::format(
      "beside the effects named after it, {} does not earn its place: the model without it "
      "leaves {:.1f} N held out against {:.1f} N with it, so it is not named",
      to_string(best->dropped), best->heldout_n, current_heldout_n);
  return best;
}

}  // namespace brakefit::gap
