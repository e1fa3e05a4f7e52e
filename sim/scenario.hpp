#pragma once
// A simulated test: bench, vehicle and wheel, tyre, sensors, and every unmodelled effect with a
// switch and a magnitude (0 / false = off). Parsed from TOML with strict validation.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/can/layout.hpp"
#include "sim/tyre.hpp"

namespace brakefit::sim {

struct Effects {
  double relaxation_length_m = 0.0;  ///< tyre lag sigma_kappa; 0 = off
  bool wheel_inertia = true;         ///< off: a negligible inertia (quasi-static wheel)
  double brake_threshold_bar = 0.0;  ///< p0 in Tb = k max(0, p - p0)
  double speed_friction = 0.0;       ///< MF 6.1 LMUV (slip-speed friction decay); 0 = off
  bool load_transfer = false;        ///< ground: vertical load from deceleration
  double roller_friction = 1.0;      ///< roller / road friction ratio; 1 = off
  bool slip_offset = false;          ///< MF 6.1 SHx, SVx
  double pressure_lag_s = 0.0;       ///< pressure sensor first-order lag
  double pressure_noise_bar = 0.0;   ///< pressure sensor noise (sigma)
  double time_offset_s = 0.0;        ///< pressure channel late by this much
  double encoder_ppr = 0.0;          ///< quantisation; 0 = ideal (10^6 ppr)
  double tester_force_lag_s =
      0.0;  ///< the tester's force reading: first-order lag; 0 = the contact force
  /// The wheel encoder is calibrated with a rolling radius (1 + this) x the true one: the
  /// measured slip is offset by about minus this (a slip offset from calibration).
  double wheel_radius_error_ratio = 0.0;
  /// Roller only: the cradle caps the braking force at this x Fz (sin beta of the wheel on the
  /// rear roller; 0 = off).
  double cradle_cap_ratio = 0.0;
  /// Outside the gap catalogue: the pressure transducer's bow through zero and 160 bar, its
  /// largest deviation (at 80 bar) this fraction of 160 bar (p + 4 a 160 x (1 - x), x = p / 160).
  double pressure_bow_ratio = 0.0;
  /// Outside the gap catalogue: friction fading with the energy slid, mu / (1 + fade d), d the
  /// integral of F v_slip / Fz dt over the run (m).
  double fade_per_m = 0.0;
  std::vector<std::string> active() const;
};

struct Scenario {
  can::BenchKind bench = can::BenchKind::Roller;
  std::uint64_t seed = 1;
  std::string pedal_ramp = "medium";  ///< slow | medium | fast, or a number in bar/s
  double ramp_bar_per_s = 25.0;
  double tyre_pressure_bar = 2.2;
  double wheel_load_n = 3800.0;
  double rolling_radius_m = 0.3;
  double wheel_inertia_kgm2 = 1.0;
  double brake_gain_nm_per_bar = 20.0;  ///< k in Tb = k (p - p0)
  double roller_diameter_m = 0.2;
  double roller_speed_kmh = 5.0;
  double roller_inertia_kgm2 = 2.0;
  double switch_off_slip_ratio = 0.27;
  double ground_speed_kmh = 40.0;
  double vehicle_mass_kg = 1300.0;
  double cg_height_m = 0.55;
  double wheelbase_m = 2.6;
  double wheel_brake_share = 0.35;  ///< share of the vehicle's braking force on the tested wheel
  double fifth_wheel_radius_m = 0.2;
  double frame_rate_hz = 1000.0;
  double dt_s = 1e-4;
  Effects effects;
  TyreMf61 tyre;
};

double ramp_rate_bar_per_s(const std::string& name);  ///< slow 10, medium 25, fast 60; throws
Scenario parse_scenario(std::string_view toml_text, const std::string& source);

}  // namespace brakefit::sim
