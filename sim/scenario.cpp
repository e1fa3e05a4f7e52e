#include "sim/scenario.hpp"

#include <charconv>

#include "core/toml_reader.hpp"

namespace brakefit::sim {

std::vector<std::string> Effects::active() const {
  std::vector<std::string> a;
  if (relaxation_length_m > 0) a.push_back("relaxation_length");
  if (wheel_inertia) a.push_back("wheel_inertia");
  if (brake_threshold_bar > 0) a.push_back("brake_threshold");
  if (speed_friction > 0) a.push_back("speed_friction");
  if (load_transfer) a.push_back("load_transfer");
  if (roller_friction != 1.0) a.push_back("roller_friction");
  if (slip_offset) a.push_back("slip_offset");
  if (pressure_lag_s > 0) a.push_back("pressure_lag");
  if (pressure_noise_bar > 0) a.push_back("pressure_noise");
  if (time_offset_s != 0) a.push_back("time_offset");
  if (encoder_ppr > 0) a.push_back("quantisation");
  if (tester_force_lag_s > 0) a.push_back("tester_force_lag");
  if (wheel_radius_error_ratio != 0) a.push_back("wheel_radius_error");
  if (cradle_cap_ratio > 0) a.push_back("cradle_cap");
  if (pressure_bow_ratio != 0) a.push_back("pressure_bow");
  if (fade_per_m > 0) a.push_back("friction_fade");
  return a;
}

double ramp_rate_bar_per_s(const std::string& name) {
  if (name == "slow") return 10.0;
  if (name == "medium") return 25.0;
  if (name == "fast") return 60.0;
  double v = 0;
  const auto [p, ec] = std::from_chars(name.data(), name.data() + name.size(), v);
  if (ec != std::errc() || p != name.data() + name.size() || !(v > 0 && v < 10000))
    throw InputError("pedal_ramp must be slow, medium, fast or a rate in bar/s");
  return v;
}

Scenario parse_scenario(std::string_view text, const std::string& source) {
  const toml::table root = parse_toml(text, source);
  TomlReader rd(source);
  rd.check_keys(root, "", {"scenario", "wheel", "roller", "ground", "sensors", "effects", "tyre"});
  Scenario s;
  if (const auto* t = rd.table(root, "", "scenario")) {
    const std::string p = "scenario.";
    rd.check_keys(*t, p,
                  {"bench", "seed", "pedal_ramp", "tyre_pressure_bar", "wheel_load_n", "dt_s"});
    const std::string bench = rd.string(*t, p, "bench", "roller");
    if (bench == "roller")
      s.bench = can::BenchKind::Roller;
    else if (bench == "ground")
      s.bench = can::BenchKind::Ground;
    else
      rd.fail(p + "bench", "expected 'roller' or 'ground'");
    s.seed = static_cast<std::uint64_t>(rd.integer(*t, p, "seed", 1, 0, INT64_MAX));
    s.pedal_ramp = rd.string(*t, p, "pedal_ramp", "medium");
    try {
      s.ramp_bar_per_s = ramp_rate_bar_per_s(s.pedal_ramp);
    } catch (const InputError& e) {
      rd.fail(p + "pedal_ramp", e.what());
    }
    s.tyre_pressure_bar = rd.number(*t, p, "tyre_pressure_bar", s.tyre_pressure_bar, 0.5, 10);
    s.wheel_load_n = rd.number(*t, p, "wheel_load_n", s.wheel_load_n, 500, 50000);
    s.dt_s = rd.number(*t, p, "dt_s", s.dt_s, 1e-6, 1e-4);
  }
  if (const auto* t = rd.table(root, "", "wheel")) {
    const std::string p = "wheel.";
    rd.check_keys(*t, p, {"rolling_radius_m", "inertia_kgm2", "brake_gain_nm_per_bar"});
    s.rolling_radius_m = rd.number(*t, p, "rolling_radius_m", s.rolling_radius_m, 0.1, 1.0);
    s.wheel_inertia_kgm2 = rd.number(*t, p, "inertia_kgm2", s.wheel_inertia_kgm2, 0.05, 50);
    s.brake_gain_nm_per_bar =
        rd.number(*t, p, "brake_gain_nm_per_bar", s.brake_gain_nm_per_bar, 0.1, 1000);
  }
  if (const auto* t = rd.table(root, "", "roller")) {
    const std::string p = "roller.";
    rd.check_keys(*t, p, {"diameter_m", "speed_kmh", "inertia_kgm2", "switch_off_slip_ratio"});
    s.roller_diameter_m = rd.number(*t, p, "diameter_m", s.roller_diameter_m, 0.1, 1.0);
    s.roller_speed_kmh = rd.number(*t, p, "speed_kmh", s.roller_speed_kmh, 1, 20);
    s.roller_inertia_kgm2 = rd.number(*t, p, "inertia_kgm2", s.roller_inertia_kgm2, 0.1, 100);
    s.switch_off_slip_ratio =
        rd.number(*t, p, "switch_off_slip_ratio", s.switch_off_slip_ratio, 0.05, 0.9);
  }
  if (const auto* t = rd.table(root, "", "ground")) {
    const std::string p = "ground.";
    rd.check_keys(*t, p,
                  {"speed_kmh", "vehicle_mass_kg", "cg_height_m", "wheelbase_m",
                   "wheel_brake_share", "fifth_wheel_radius_m"});
    s.ground_speed_kmh = rd.number(*t, p, "speed_kmh", s.ground_speed_kmh, 5, 150);
    s.vehicle_mass_kg = rd.number(*t, p, "vehicle_mass_kg", s.vehicle_mass_kg, 100, 60000);
    s.cg_height_m = rd.number(*t, p, "cg_height_m", s.cg_height_m, 0.1, 3);
    s.wheelbase_m = rd.number(*t, p, "wheelbase_m", s.wheelbase_m, 1, 10);
    s.wheel_brake_share = rd.number(*t, p, "wheel_brake_share", s.wheel_brake_share, 0.05, 1);
    s.fifth_wheel_radius_m =
        rd.number(*t, p, "fifth_wheel_radius_m", s.fifth_wheel_radius_m, 0.05, 1);
  }
  if (const auto* t = rd.table(root, "", "sensors")) {
    const std::string p = "sensors.";
    rd.check_keys(*t, p, {"frame_rate_hz"});
    s.frame_rate_hz = rd.number(*t, p, "frame_rate_hz", s.frame_rate_hz, 10, 10000);
  }
  if (const auto* t = rd.table(root, "", "effects")) {
    const std::string p = "effects.";
    rd.check_keys(
        *t, p,
        {"relaxation_length_m", "wheel_inertia", "brake_threshold_bar", "speed_friction",
         "load_transfer", "roller_friction", "slip_offset", "pressure_lag_s", "pressure_noise_bar",
         "time_offset_s", "encoder_ppr", "tester_force_lag_s", "wheel_radius_error_ratio",
         "cradle_cap_ratio", "pressure_bow_ratio", "fade_per_m"});
    auto& e = s.effects;
    e.relaxation_length_m = rd.number(*t, p, "relaxation_length_m", e.relaxation_length_m, 0, 2);
    e.wheel_inertia = rd.boolean(*t, p, "wheel_inertia", e.wheel_inertia);
    e.brake_threshold_bar = rd.number(*t, p, "brake_threshold_bar", e.brake_threshold_bar, 0, 50);
    e.speed_friction = rd.number(*t, p, "speed_friction", e.speed_friction, 0, 10);
    e.load_transfer = rd.boolean(*t, p, "load_transfer", e.load_transfer);
    e.roller_friction = rd.number(*t, p, "roller_friction", e.roller_friction, 0.1, 1.5);
    e.slip_offset = rd.boolean(*t, p, "slip_offset", e.slip_offset);
    e.pressure_lag_s = rd.number(*t, p, "pressure_lag_s", e.pressure_lag_s, 0, 1);
    e.pressure_noise_bar = rd.number(*t, p, "pressure_noise_bar", e.pressure_noise_bar, 0, 10);
    e.time_offset_s = rd.number(*t, p, "time_offset_s", e.time_offset_s, 0, 1);
    e.encoder_ppr = rd.number(*t, p, "encoder_ppr", e.encoder_ppr, 0, 1e6);
    e.tester_force_lag_s = rd.number(*t, p, "tester_force_lag_s", e.tester_force_lag_s, 0, 1);
    e.wheel_radius_error_ratio =
        rd.number(*t, p, "wheel_radius_error_ratio", e.wheel_radius_error_ratio, -0.1, 0.1);
    e.cradle_cap_ratio = rd.number(*t, p, "cradle_cap_ratio", e.cradle_cap_ratio, 0, 2);
    e.pressure_bow_ratio = rd.number(*t, p, "pressure_bow_ratio", e.pressure_bow_ratio, -0.2, 0.2);
    e.fade_per_m = rd.number(*t, p, "fade_per_m", e.fade_per_m, 0, 100);
  }
  if (const auto* t = rd.table(root, "", "tyre")) {
    const std::string p = "tyre.";
    rd.check_keys(*t, p,
                  {"family", "FNOMIN", "NOMPRES_bar", "PCX1", "PDX1", "PDX2", "PEX1", "PEX2",
                   "PEX3", "PEX4", "PKX1", "PKX2", "PKX3", "PPX1", "PPX2", "PPX3", "PPX4"});
    auto& ty = s.tyre;
    const std::string family = rd.string(*t, p, "family", "magic_formula");
    if (family == "burckhardt")
      ty.family = TyreMf61::Family::Burckhardt;
    else if (family != "magic_formula")
      rd.fail(p + "family", "expected 'magic_formula' or 'burckhardt'");
    ty.FNOMIN = rd.number(*t, p, "FNOMIN", ty.FNOMIN, 100, 1e5);
    ty.NOMPRES_bar = rd.number(*t, p, "NOMPRES_bar", ty.NOMPRES_bar, 0.5, 10);
    ty.PCX1 = rd.number(*t, p, "PCX1", ty.PCX1, 1.0, 2.0);
    ty.PDX1 = rd.number(*t, p, "PDX1", ty.PDX1, 0.1, 3);
    ty.PDX2 = rd.number(*t, p, "PDX2", ty.PDX2, -2, 2);
    ty.PEX1 = rd.number(*t, p, "PEX1", ty.PEX1, -10, 1);
    ty.PEX2 = rd.number(*t, p, "PEX2", ty.PEX2, -10, 10);
    ty.PEX3 = rd.number(*t, p, "PEX3", ty.PEX3, -10, 10);
    ty.PEX4 = rd.number(*t, p, "PEX4", ty.PEX4, -1, 1);
    ty.PKX1 = rd.number(*t, p, "PKX1", ty.PKX1, 1, 100);
    ty.PKX2 = rd.number(*t, p, "PKX2", ty.PKX2, -100, 100);
    ty.PKX3 = rd.number(*t, p, "PKX3", ty.PKX3, -10, 10);
    ty.PPX1 = rd.number(*t, p, "PPX1", ty.PPX1, -5, 5);
    ty.PPX2 = rd.number(*t, p, "PPX2", ty.PPX2, -5, 5);
    ty.PPX3 = rd.number(*t, p, "PPX3", ty.PPX3, -5, 5);
    ty.PPX4 = rd.number(*t, p, "PPX4", ty.PPX4, -5, 5);
  }
  return s;
}

}  // namespace brakefit::sim
