// Speed friction against a friction that fades with the energy slid. Where the runs' speeds
// differ, a faster run slides more per unit of slip and so heats the tyre more: a fade looks like
// a friction falling with the sliding speed. The evidence only speed friction leaves is a
// friction that follows the sliding speed now, whatever the run slid before; a fade follows the
// energy slid so far (a slow ramp fades more at the same slip and speed). The fade is outside the
// catalogue: it is fitted as a rival, never named.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

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

std::optional<FadeRival> fade_rival(const std::vector<Run>& runs, const std::vector<Effect>& chosen,
                                    double current_heldout_n, const Fitter& fit, const Options& o) {
  if (std::find(chosen.begin(), chosen.end(), Effect::SpeedFriction) == chosen.end())
    return std::nullopt;
  FadeRival f;
  f.model = chosen;
  std::replace(f.model.begin(), f.model.end(), Effect::SpeedFriction, Effect::FrictionFade);
  f.heldout_n = heldout(runs, f.model, fit);
  // Speed friction is named only where it beats the fade by the gain gate held out.
  if (current_heldout_n < (1.0 - o.gate_gain) * f.heldout_n) return std::nullopt;
  const Fit all = fit(pointers(runs), f.model);
  f.fade_per_kj = all.params.at(*param_offset(f.model, Effect::FrictionFade));
  f.note = fmt::format(
      "speed_friction leaves {:.1f} N held out, but a friction fading with the energy the tyre "
      "slid so far (mu / (1 + k E), k = {:.3g} per kJ, outside the catalogue) leaves {:.1f} N in "
      "its place: speed friction does not beat it by the gain gate ({:.0f} %), so the friction "
      "falling on the faster runs is not shown to follow the sliding speed and nothing is named",
      current_heldout_n, f.fade_per_kj, f.heldout_n, 100 * o.gate_gain);
  return f;
}

}  // namespace brakefit::gap
