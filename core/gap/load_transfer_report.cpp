// Load transfer as the report gives it: its magnitude at the tyre's load laws, as
// dFz/Fz and as h/L, and the body's pitch it follows.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// The body's pitch as a person reads it: a mode's frequency and damping ratio (m x'' + lag x' +
/// x = a: w = 1 / sqrt(m), zeta = lag w / 2), or the lag alone.
void pitch_note(Report& rep, EffectScore& e) {
  double lag_s = 0, mode_s2 = 0;
  for (const auto& [name, v] : e.params) {
    if (name == "pitch_lag_s") lag_s = v;
    if (name == "pitch_mode_s2") mode_s2 = v;
  }
  // A mode above 3 Hz (m under 2.8e-3 s^2), or one that does not overshoot, is a lag: a body's
  // pitch is 1-1.5 Hz, and a faster or overdamped mode follows a brake's ramp as a lag does.
  const double zeta_at = mode_s2 > 0 ? 0.5 * lag_s / std::sqrt(mode_s2) : INFINITY;
  if (mode_s2 < 2.8e-3 || zeta_at >= 1.0) {
    rep.notes.push_back(fmt::format(
        "the wheel's load follows the deceleration {:.3f} s behind it (the body's pitch, as a "
        "first-order lag)",
        lag_s));
    return;
  }
  const double hz = 1.0 / (2 * M_PI * std::sqrt(mode_s2));
  e.params.emplace_back("pitch_mode_hz", hz);
  e.params.emplace_back("pitch_damping_ratio", zeta_at);
  rep.notes.push_back(fmt::format(
      "the wheel's load follows the deceleration through the body's pitch mode: {:.2f} Hz, "
      "damping ratio {:.2f} (it overshoots a step; {:.3f} s behind it on a steady ramp)",
      hz, zeta_at, lag_s));
}

}  // namespace

std::vector<Effect> at_tyre_load_laws(std::vector<Effect> model) {
  std::replace(model.begin(), model.end(), Effect::LoadTransfer, Effect::LoadTransferMeasured);
  return model;
}

double median_wheel_load_n(const std::vector<Run>& runs) {
  std::vector<double> loads;
  for (const Run& r : runs)
    if (r.wheel_load_n > 0) loads.push_back(r.wheel_load_n);
  std::sort(loads.begin(), loads.end());
  return loads.empty() ? 0.0 : loads[loads.size() / 2];
}

/// Load transfer, once named, is measured with the stiffness ratio held at the tyre's load laws
/// (Options::tyre_load_laws: its own file's or published tyres'; Effect::LoadTransferMeasured): its
/// score's magnitude is that fit's q; the free fit's q stays beside it
/// (dfz_per_decel_free_ratio_s2_per_m). Its free ratio has decided the naming (inside its range)
/// and its fit stays the model's: a note says both.
void measure_load_transfer(Report& rep, const std::vector<Run>& runs, const Fitter& fit,
                           const Options& o) {
  const std::vector<Effect> model = at_tyre_load_laws(rep.accepted);
  if (model == rep.accepted) return;
  const std::size_t at_q = *param_offset(model, Effect::LoadTransferMeasured);
  const double q = fit(pointers(runs), model).params.at(at_q);
  // Without the tyre's file the laws are published tyres', which differ from one tyre to another
  // by more than the runs' noise moves the magnitude: it is read at each end of their spread too
  // (the slip stiffness's ratio moves the fitted peak scale; the peak's exponent turns that into
  // the load's change).
  const bool own = !o.tyre_load_laws_source.empty();
  const tyre::PublishedLoadLawRange& pub = tyre::kPublishedLoadLawRange;
  std::array<double, 2> band{NAN, NAN};
  if (!own) {
    band = {q / pub.peak_exponent_high, q / pub.peak_exponent_low};
    std::vector<Run> at = runs;
    for (const double ratio : {pub.kx_over_peak_low, pub.kx_over_peak_high}) {
      for (Run& r : at) r.load_laws.kx_over_peak = ratio;
      const double q_at = fit(pointers(at), model).params.at(at_q);
      band[0] = std::min(band[0], q_at / pub.peak_exponent_high);
      band[1] = std::max(band[1], q_at / pub.peak_exponent_low);
    }
  }
  const double fz_n = median_wheel_load_n(runs);
  for (auto& e : rep.effects) {
    if (e.effect != Effect::LoadTransfer || !e.accepted || e.params.size() < 2) continue;
    const double q_free = e.params[0].second, ratio = e.params[1].second;
    e.params[0].second = q;
    e.params.emplace_back("dfz_per_decel_free_ratio_s2_per_m", q_free);
    const tyre::LoadLaws& laws = o.tyre_load_laws;
    const double load_per_decel = q / laws.peak_exponent;
    e.params.emplace_back("load_ratio_per_decel_s2_per_m", load_per_decel);
    if (!own) {
      e.params.emplace_back("load_ratio_per_decel_low_s2_per_m", band[0]);
      e.params.emplace_back("load_ratio_per_decel_high_s2_per_m", band[1]);
    }
    e.params.emplace_back("kx_load_ratio_held", laws.kx_over_peak);
    e.params.emplace_back("peak_load_exponent", laws.peak_exponent);
    std::string h_over_l;
    if (o.vehicle_mass_kg > 0 && fz_n > 0) {
      const double per_load = 2.0 * fz_n / o.vehicle_mass_kg;
      const double v = per_load * load_per_decel;
      e.params.emplace_back("cg_height_over_wheelbase", v);
      if (!own) {
        e.params.emplace_back("cg_height_over_wheelbase_low", per_load * band[0]);
        e.params.emplace_back("cg_height_over_wheelbase_high", per_load * band[1]);
      }
      h_over_l = fmt::format(
          "; with the vehicle's {:.0f} kg and the wheel's {:.0f} N, the centre of gravity's "
          "height over the wheelbase is {:.3f}{} (h/L = 2 Fz (dFz/Fz per m/s^2) / m)",
          o.vehicle_mass_kg, fz_n, v,
          own ? std::string()
              : fmt::format(", {:.3f}-{:.3f} at the ends of the published laws", per_load * band[0],
                            per_load * band[1]));
    }
    const std::string whose =
        own ? fmt::format("the tyre's own file, {}, at the runs' wheel load",
                          o.tyre_load_laws_source)
            : fmt::format(
                  "car and van MF 6.1 tyres of published ranges (their ratios {:.2f}-{:.2f}, "
                  "d ln D / d ln Fz {:.2f}-{:.2f}; the tyre's own file, where given, reads them "
                  "at its own)",
                  pub.kx_over_peak_low, pub.kx_over_peak_high, pub.peak_exponent_low,
                  pub.peak_exponent_high);
    const std::string spread =
        own ? std::string()
            : fmt::format(
                  ". At the ends of those tyres' laws it reads {:.4g}-{:.4g}: the spread their "
                  "laws alone leave, before the runs' own noise (a tyre whose laws lie outside "
                  "them reads outside it; its file, --tir, removes the spread)",
                  band[0], band[1]);
    rep.notes.push_back(fmt::format(
        "load_transfer's magnitude, {:.4g} per m/s^2, is measured with the slip stiffness's load "
        "ratio held at {:.2f} and E moving by {:.3f} per unit of the peak's change, the load laws "
        "of {}: the runs end just past the peak and fix the stiffness's load sensitivity (q x "
        "ratio) better than q; the free fit says {:.4g} at a ratio of {:.2f}. The wheel's load "
        "changes by {:.4g} of itself per m/s^2 (dFz/Fz: the peak's change over d ln D / d ln Fz, "
        "{:.3f}){}{}",
        q, laws.kx_over_peak, laws.e_per_peak_scale, whose, q_free, ratio, load_per_decel,
        laws.peak_exponent, spread, h_over_l));
    pitch_note(rep, e);
  }
}

}  // namespace brakefit::gap
