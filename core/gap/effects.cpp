// The candidate effects: their names, parameters and physical ranges, and where each model's
// parameters sit. (The augmented model that adds them to the Magic Formula is predict.cpp's.)
#include <algorithm>
#include <cmath>
#include <optional>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

const char* to_string(Effect e) {
  switch (e) {
    case Effect::RelaxationLength:
      return "relaxation_length";
    case Effect::TimeOffset:
      return "time_offset";
    case Effect::WheelInertia:
      return "wheel_inertia";
    case Effect::BrakeThreshold:
      return "brake_threshold";
    case Effect::SlipOffset:
      return "slip_offset";
    case Effect::LoadTransfer:
    case Effect::LoadTransferShape:
    case Effect::LoadTransferMeasured:
      return "load_transfer";
    case Effect::SpeedFriction:
      return "speed_friction";
    case Effect::RollerFriction:
      return "roller_friction";
    case Effect::CradleCap:
      return "cradle_cap";
    case Effect::ReferenceBias:
      return "reference_bias";
    case Effect::TyreShift:
      return "tyre_shift";
    case Effect::FrictionFade:
      return "friction_fade";
  }
  return "?";
}

const char* to_string(Condition c) {
  switch (c) {
    case Condition::Roller:
      return "roller";
    case Condition::Ground:
      return "ground";
    case Condition::RollerToRoad:
      return "roller_vs_road";
  }
  return "?";
}

std::span<const EffectParam> effect_params(Effect e) {
  // q scales the peak D by 1 + q x deceleration; the slip stiffness B C D scales by
  // (1 + q x deceleration)^r: a tyre's stiffness and peak grow differently with load (MF 6.1:
  // PKX1-3 vs PDX1-2; r 1.3 for the simulated TNO 205/60R15), and one ratio for both misread q by
  // 40 %. Against a held curve E moves with the load as well (PEX2: E += e x relative load).
  // Built once: predict() asks for every evaluation of the fits.
  constexpr auto kEffects = static_cast<std::size_t>(Effect::FrictionFade) + 1;
  static const std::array<std::vector<EffectParam>, kEffects> table = [] {
    std::array<std::vector<EffectParam>, kEffects> t;
    for (std::size_t i = 0; i < kEffects; ++i) t[i] = {effect_param(static_cast<Effect>(i))};
    // The body's pitch: the load follows the deceleration through m x'' + lag x' + x = a, m the
    // pitch mode's 1 / w^2 (0: a first-order lag; 0.1 s^2: a mode of 0.5 Hz).
    constexpr EffectParam kPitchLag{"pitch_lag_s", 0.0, 0.3, 0.05, true};
    constexpr EffectParam kPitchMode{"pitch_mode_s2", 0.0, 0.1, 0.0, true};
    t[static_cast<std::size_t>(Effect::LoadTransfer)].push_back({"kx_load_ratio", 0.0, 3.0, 1.0});
    t[static_cast<std::size_t>(Effect::LoadTransfer)].push_back(kPitchLag);
    t[static_cast<std::size_t>(Effect::LoadTransfer)].push_back(kPitchMode);
    t[static_cast<std::size_t>(Effect::LoadTransferMeasured)].push_back(kPitchLag);
    t[static_cast<std::size_t>(Effect::LoadTransferMeasured)].push_back(kPitchMode);
    auto& shape = t[static_cast<std::size_t>(Effect::LoadTransferShape)];
    shape.push_back({"kx_load_ratio", 0.0, 3.0, 1.0});
    shape.push_back({"e_per_load", -2.0, 2.0, 0.0});
    shape.push_back(kPitchLag);
    shape.push_back(kPitchMode);
    return t;
  }();
  return table[static_cast<std::size_t>(e)];
}

std::size_t param_count(const std::vector<Effect>& effects) {
  std::size_t n = 4;
  for (Effect e : effects) n += effect_params(e).size();
  return n;
}

std::optional<std::size_t> param_offset(const std::vector<Effect>& model, Effect e) {
  std::size_t at = 4;
  for (Effect m : model) {
    if (m == e) return at;
    at += effect_params(m).size();
  }
  return std::nullopt;
}

std::vector<std::string> param_names(const std::vector<Effect>& effects) {
  std::vector<std::string> names{"B", "C", "D", "E"};
  for (Effect e : effects)
    for (const auto& p : effect_params(e)) names.emplace_back(p.name);
  return names;
}

EffectParam effect_param(Effect e) {
  switch (e) {
    case Effect::RelaxationLength:
      return {"sigma_m", 1e-4, 2.0, 0.05};
    case Effect::TimeOffset:
      return {"dt_s", -0.3, 0.3, 0.0};
    // The lower end of these three is the effect absent, where a fit explains nothing and the
    // gates refuse it; judged as an edge, the range's 0.5 % (0.5 kg m^2 on a range sized for
    // trucks, 0.15 bar) would refuse a car's wheel and an air brake's threshold.
    case Effect::WheelInertia:
      return {"inertia_kgm2", 0.0, 100.0, 0.5, true};  // a truck wheel end: 20-80 kg m^2
    case Effect::BrakeThreshold:
      return {"p0_bar", 0.0, 30.0, 1.0, true};  // a dead zone: the pads bite from p0 on
    case Effect::SlipOffset:
      return {"slip_offset_ratio", -0.05, 0.05, 0.0};
    case Effect::LoadTransfer:
    case Effect::LoadTransferShape:
    case Effect::LoadTransferMeasured:
      return {"dfz_per_decel_s2_per_m", -0.2, 0.2, 0.0};
    case Effect::SpeedFriction:
      return {"lambda_mu_v", 0.0, 20.0, 0.1, true};
    case Effect::RollerFriction:
      return {"mu_ratio", 0.3, 2.0, 1.0};
    case Effect::CradleCap:
      return {"cap_n", 100.0, 1e5, 0.0};  // start and fit range: from the runs' peak force
    case Effect::ReferenceBias:           // range: the runs' ref_bias_bound
      return {"reference_slip_bias_ratio", -0.01, 0.01, 0.0};
    case Effect::TyreShift:  // range: kTyreShiftBoundRatio and the runs' ref_bias_bound
      return {"tyre_shift_ratio", -0.01, 0.01, 0.0};
    case Effect::FrictionFade:  // mu / (1 + k E), E the energy slid so far in kJ
      return {"fade_per_kj", 0.0, 20.0, 0.1, true};
  }
  return {"?", 0, 0, 0};
}

}  // namespace brakefit::gap
