// Each named effect against a friction that fades with the energy slid. A fade changes the curve
// from run to run and along each run: where the runs' speeds differ, a faster run slides more per
// unit of slip and heats the tyre more, as a friction falling with the sliding speed does; at one
// speed a slow ramp slides longest before its peak and fades most, and an inertia's or a lag's
// run-to-run terms take part of that. The fade follows the energy slid so far, whatever the slip
// and speed now. It is outside the catalogue: it is fitted as a rival, never named.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {
// How many times less the fade must leave than the model naming the effect, to veto it, held
// out (beside a second effect, a tie held out is no evidence against the effect).
constexpr double kFadeMargin = 2.0;
// Judged in-sample the comparison is like for like (the same points, one parameter each): the
// law that leaves less is the better account, by BIC as by the error. But a fade that takes
// less than this share of the friction by the most energy any run slid is the model without
// the effect, not a fade (whether the effect is needed is the needless-effect check's to say):
// B's true pairs beside load transfer whose members a fade fitted alike ended at k E under
// 0.001; B's fading tyres named with load transfer, 0.04-0.17.
constexpr double kFadeMinShare = 0.01;

/// The most energy any run slid by its end, kJ.
double most_slid_kj(const std::vector<Run>& runs) {
  double e_kj = 0;
  for (const Run& r : runs)
    if (const auto e = slid_energy_kj(r); !e.empty()) e_kj = std::max(e_kj, e.back());
  return e_kj;
}
}  // namespace

std::vector<double> slid_energy_kj(const Run& r) {
  const std::size_t n = r.t_s.size();
  std::vector<double> e_kj(n, 0.0);
  if (r.force_n.size() != n || r.slip.size() != n || r.v_ref_mps.size() != n) return e_kj;
  // The power the contact turns into heat, |F| x |slip| x V (the sliding speed times the force),
  // integrated by trapezoids.
  auto power_kw = [&](std::size_t i) {
    return std::abs(r.force_n[i]) * std::abs(r.slip[i]) * std::abs(r.v_ref_mps[i]) * 1e-3;
  };
  for (std::size_t i = 1; i < n; ++i)
    e_kj[i] = e_kj[i - 1] + 0.5 * (power_kw(i - 1) + power_kw(i)) * (r.t_s[i] - r.t_s[i - 1]);
  return e_kj;
}

std::optional<std::string> fade_rival(const std::vector<Run>& runs,
                                      const std::vector<Effect>& chosen, const Fit& current,
                                      double current_heldout_n, double gap_before_n,
                                      const Fitter& fit) {
  // Beside load transfer the model was judged on every run at once (one run left out, load
  // transfer's fold trades the tyre's shape for the load): the fade is compared the same way.
  const bool in_sample = std::any_of(chosen.begin(), chosen.end(), is_load_transfer);
  // Where held out the model does no better than none, its only support is in-sample (B's
  // fading tyres named load transfer with speed friction), and there the fade is judged like for
  // like: the fade that leaves less and fades is. (A model that does better held out keeps the
  // held-out margin: B's load transfer named with a heavy wheel, where a 3 % fade fitted 5 %
  // closer in-sample.)
  const bool like_for_like = in_sample && current_heldout_n >= gap_before_n;
  const double e_kj = in_sample ? most_slid_kj(runs) : 0.0;
  const double current_n = in_sample ? in_sample_rms(current) : current_heldout_n;
  for (const Effect e : named_effects(chosen)) {
    // Load transfer itself is always judged like for like, whatever held out said: its four
    // parameters against the fade's one on the same points, a fade that leaves less in its place
    // is the better account by any count of parameters (B's fading tyres named load transfer
    // with speed friction, where the friction's model did better held out than none).
    const bool against_fewer = is_load_transfer(e);
    const bool alike = like_for_like || against_fewer;
    std::vector<Effect> model = chosen;
    std::replace(model.begin(), model.end(), e, Effect::FrictionFade);
    const Fit all = fit(pointers(runs), model);
    const double rival_n = in_sample ? in_sample_rms(all) : heldout(runs, model, fit);
    const double k_per_kj = all.params.at(*param_offset(model, Effect::FrictionFade));
    // Held out, beside a second effect the fade often fits about as well (the other effect takes
    // up the difference), so a tie is no evidence against the effect; only a fade that leaves
    // under half of what the effect leaves is a better account of the runs.
    const double faded_share = k_per_kj * e_kj / (1.0 + k_per_kj * e_kj);  // k E / (1 + k E)
    const double margin = alike ? 1.0 : kFadeMargin;
    if (rival_n * margin >= current_n || (alike && faded_share < kFadeMinShare)) continue;
    return fmt::format(
        "the model naming {} leaves {:.1f} N {}, but a friction fading with the energy the tyre "
        "slid so far (mu / (1 + k E), k = {:.3g} per kJ, outside the catalogue) leaves {:.1f} N "
        "in its place ({}): the runs follow the energy slid better, so nothing is named",
        to_string(e), current_n, in_sample ? "in-sample" : "held out", k_per_kj, rival_n,
        alike ? fmt::format("less, on the same points with {}; the fade takes {:.0f} % of the "
                            "friction by the most any run slid",
                            against_fewer ? "one parameter against load transfer's four"
                                          : "one parameter each",
                            100 * faded_share)
              : fmt::format("under 1/{:g}", kFadeMargin));
  }
  return std::nullopt;
}

}  // namespace brakefit::gap
