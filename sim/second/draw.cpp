// Generator B's sets: the tyre libraries (.tir files) and a set's draw (the station, the
// vehicle, its runs and the effects injected into them, each checked against its law).
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/curve.hpp"
#include "sim/second/generator.hpp"

namespace brakefit::sim2 {

namespace {

constexpr double kG = 9.81;

std::vector<Mf61Longitudinal> read_tyres(const std::filesystem::path& dir) {
  std::vector<Mf61Longitudinal> out;
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".tir") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& p : files) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    out.push_back(mf61_from_tir(parse_tir(ss.str(), p.string()), p.stem().string()));
  }
  if (out.empty()) throw InputError("no .tir files in " + dir.string());
  return out;
}

}  // namespace

const std::vector<Mf61Longitudinal>& tyre_library() {
  static const auto lib = read_tyres(BRAKEFIT_SIM2_TYRE_DIR);
  return lib;
}

const std::vector<Mf61Longitudinal>& heavy_tyre_library() {
  static const auto lib = read_tyres(std::filesystem::path(BRAKEFIT_SIM2_TYRE_DIR) / "heavy");
  return lib;
}

namespace {

/// d ln D / d ln Fz of an MF 6.1 tyre at a load (the load transfer's effect on the peak).
double d_ln_d_per_ln_fz(const Mf61Longitudinal& t, double fz_n, double pressure_pa) {
  auto peak = [&](double fz) {
    Contact k;
    k.fz_n = fz;
    k.pressure_pa = pressure_pa;
    // Slips 0.01 to 0.598 by 0.002, accumulated as drawn sets have always been.
    double best = 0, s = 0.01;
    for (int i = 0; i < 295; ++i, s += 0.002) best = std::max(best, mf61_braking_force_n(t, s, k));
    return best;
  };
  return std::log(peak(fz_n * 1.02) / peak(fz_n / 1.02)) / std::log(1.02 * 1.02);
}

/// An effect this generator injects, with a magnitude its law can take: an unknown name would
/// make a null set labelled with it, and a wheel without inertia a wheel equation that never
/// steps on (w' = (F R - Tb) / I).
void check_effect(const std::string& effect, double magnitude) {
  struct Law {
    const char* name;
    double lo, hi;  // the magnitude's range, open at lo where lo_open
    bool lo_open;
  };
  static constexpr std::array<Law, 11> laws = {{{"none", -INFINITY, INFINITY, false},
                                                {"misspecified", -INFINITY, INFINITY, false},
                                                {"load_transfer", -INFINITY, INFINITY, false},
                                                {"relaxation_length", 0.0, 10.0, false},
                                                {"wheel_inertia", 0.0, 200.0, true},
                                                {"brake_threshold", 0.0, 100.0, false},
                                                {"time_offset", -1.0, 1.0, false},
                                                {"slip_offset", -0.5, 0.5, false},
                                                {"speed_friction", 0.0, 100.0, false},
                                                {"pressure_bow", -0.2, 0.2, false},
                                                {"friction_fade", 0.0, 100.0, false}}};
  const auto l =
      std::find_if(laws.begin(), laws.end(), [&](const Law& law) { return effect == law.name; });
  if (l == laws.end()) {
    std::string known;
    for (const Law& law : laws) known += (known.empty() ? "" : ", ") + std::string(law.name);
    throw InputError(fmt::format("generator B: unknown effect '{}' (known: {})", effect, known));
  }
  const bool above = l->lo_open ? magnitude > l->lo : magnitude >= l->lo;
  if (!std::isfinite(magnitude) || !above || magnitude > l->hi)
    throw InputError(fmt::format("generator B: {} magnitude {} is outside {}{}, {}]", effect,
                                 magnitude, l->lo_open ? "(" : "[", l->lo, l->hi));
}

}  // namespace

SetDraw draw_set(can::BenchKind bench, const std::vector<EffectDraw>& effects, std::uint64_t seed,
                 Stations stations) {
  for (const auto& d : effects) check_effect(d.effect, d.magnitude);
  Rng rng(seed * 7919 + 17);
  // The wider station draws take their own stream: a Cars set of a seed stays what it was.
  Rng srng(seed * 104729 + 5);
  const bool every = stations == Stations::Every;
  const bool heavy = every && srng.uniform() < 0.25;
  const auto& lib = tyre_library();
  RunCase base;
  base.bench = bench;
  base.tyre = lib[rng.index(lib.size())];
  base.fz_n = base.tyre.fnomin_n * rng.uniform(0.8, 1.15);
  base.pressure_pa = base.tyre.nompres_pa * rng.uniform(0.8, 1.1);
  base.radius_m = rng.uniform(0.28, 0.34);
  // No inertia effect: a light wheel (its I a / R^2 well below the force noise; on the ground the
  // wheel's deceleration is ten times the roller's).
  base.inertia_kgm2 =
      bench == can::BenchKind::Roller ? rng.uniform(0.02, 0.05) : rng.uniform(0.005, 0.015);
  // A heavy vehicle is scaled against a car: air brakes to 8 bar (160 bar hydraulics), a wheel's
  // inertia by R^2 Fz; the null's light wheel and the effects drawn alike.
  double pressure_scale = 1, inertia_scale = 1;
  if (heavy) {
    const auto& hl = heavy_tyre_library();
    base.tyre = hl[srng.index(hl.size())];
    base.fz_n = std::min(40000.0, base.tyre.fnomin_n * srng.uniform(0.6, 1.15));
    base.pressure_pa = base.tyre.nompres_pa * srng.uniform(0.85, 1.05);
    base.radius_m = srng.uniform(0.48, 0.54);
    pressure_scale = 8.0 / 160.0;
    inertia_scale = base.radius_m * base.radius_m * base.fz_n / (0.31 * 0.31 * 4000.0);
    base.inertia_kgm2 *= inertia_scale;
  }
  Contact k;
  k.fz_n = base.fz_n;
  k.pressure_pa = base.pressure_pa;
  double peak_n = 0, s = 0.01;  // slips 0.01 to 0.495 by 0.005, accumulated
  for (int i = 0; i < 98; ++i, s += 0.005)
    peak_n = std::max(peak_n, mf61_braking_force_n(base.tyre, s, k));
  // Brake sized so that the peak needs 45-75 bar (2.25-3.75 bar of air).
  base.brake_gain_nm_per_bar = peak_n * base.radius_m / (rng.uniform(45, 75) * pressure_scale);
  base.max_pressure_bar = 160 * pressure_scale;
  TesterExport& tx = base.tester;
  tx.sample_hz = rng.uniform() < 0.3 ? 500 : 1000;
  tx.jitter_ratio = rng.uniform(0.05, 0.25);
  tx.stamp_resolution_s = tx.sample_hz >= 1000 ? 1e-3 : 1e-4;
  tx.speed_step_mps = rng.uniform(0.0005, 0.003);
  tx.pressure_filter_s = rng.uniform(0.005, 0.02);
  tx.pressure_step_bar = rng.uniform() < 0.5 ? 0.01 : 0.05;
  tx.pressure_noise_bar = rng.uniform(0.01, 0.05);
  tx.eccentricity_ref = rng.uniform(0, 5e-4);
  tx.eccentricity_wheel = rng.uniform(0, 5e-4);
  tx.switch_off_slip = rng.uniform(0.255, 0.285);
  tx.lock_slip = rng.uniform(0.9, 0.94);
  if (every) {
    tx.sample_hz = std::array{50.0, 100.0, 200.0, 250.0, 500.0, 1000.0}[srng.index(6)];
    tx.stamp_resolution_s = tx.sample_hz >= 1000 ? 1e-3 : 1e-4;
  }
  if (heavy) {  // a heavy-vehicle lane's transducers: 1 mm/s, 0.01 bar on an 8 bar range
    tx.speed_step_mps = 0.001;
    tx.pressure_step_bar = 0.01;
    tx.pressure_noise_bar = srng.uniform(0.002, 0.01);
  }
  // The vehicle (ground): front share of the mass 0.5-0.6 on this axle; h/L 0.15-0.35.
  const double front_share = rng.uniform(0.5, 0.6);
  base.mass_kg = 2 * base.fz_n / (front_share * kG);
  const double h_over_l = rng.uniform(0.15, 0.35);
  // The body's pitch (its own stream: the other draws of a seed stay as they were): half the
  // vehicles let the load follow the deceleration 0-0.2 s behind it, half through a damped pitch
  // mode of 1-1.5 Hz (damping 0.3-0.7, a car's suspension; a truck's mode is as slow).
  Rng prng(seed * 15485863 + 29);
  if (prng.uniform() < 0.5) {
    base.pitch_lag_s = prng.uniform(0.0, 0.2);
  } else {
    base.pitch_hz = prng.uniform(1.0, 1.5);
    base.pitch_damping = prng.uniform(0.3, 0.7);
  }
  base.other_brakes_ratio = 1.0 + 2.0 * rng.uniform(0.3, 0.6);  // the other front + two rears
  base.other_mu = rng.uniform(0.9, 1.1);
  SetDraw out;
  for (const auto& [effect, magnitude, load_given] : effects) {
    double truth = magnitude;
    if (effect == "relaxation_length") base.relaxation_m = magnitude;
    if (effect == "wheel_inertia") base.inertia_kgm2 = truth = magnitude * inertia_scale;
    if (effect == "brake_threshold") base.threshold_bar = truth = magnitude * pressure_scale;
    if (effect == "time_offset") base.time_offset_s = magnitude;
    if (effect == "slip_offset") base.radius_error_ratio = -magnitude;
    if (effect == "speed_friction") base.lmuv = magnitude;
    if (effect == "pressure_bow") tx.pressure_bow_ratio = magnitude;
    if (effect == "friction_fade") base.fade_per_m = magnitude;
    if (effect == "load_transfer") {
      // dFz / Fz per m/s^2 = m h / (2 L Fz0) = h/L / (front share g); D follows through MF 6.1.
      const double d_ln_d = d_ln_d_per_ln_fz(base.tyre, base.fz_n, base.pressure_pa);
      base.load_per_decel = load_given ? magnitude / d_ln_d : h_over_l / (front_share * kG);
      truth = base.load_per_decel * d_ln_d;
    }
    if (effect == "misspecified") {
      base.brush = true;
      base.brush_tyre.cx_n = mf61_slip_stiffness_n(base.tyre, k);
      base.brush_tyre.mu_static = peak_n / base.fz_n * rng.uniform(1.0, 1.1);
      base.brush_tyre.mu_kinetic = base.brush_tyre.mu_static * rng.uniform(0.6, 0.85);
      base.brush_tyre.v_c_mps = rng.uniform(0.3, 2.0);
      // On the road the runs' speeds differ: a friction that falls with the sliding speed is
      // speed friction there (in the catalogue), not a curve that is no Magic Formula. The road's
      // brush tyre slides at one friction; on the roller, at one speed, the fall only shapes
      // the curve.
      if (bench != can::BenchKind::Roller) base.brush_tyre.mu_kinetic = base.brush_tyre.mu_static;
    }
    out.magnitudes.push_back(truth);
  }
  out.magnitude = out.magnitudes.empty() ? 0.0 : out.magnitudes.front();
  // Cars: three runs, roller at 5 km/h with three pedal ramps, ground at 30, 50, 70 km/h. Every:
  // 2-6 runs, one roller speed a station (its drive drooping under the brake's load) with pedal
  // ramps spread log-uniformly over 6-75 bar/s, ground speeds spread over 30-130 km/h.
  const int n_runs = every ? 2 + static_cast<int>(srng.index(5)) : 3;
  const double roller_kmh = heavy ? srng.uniform(2, 3) : srng.uniform(2, 6);
  const double droop = heavy ? srng.uniform(0.02, 0.05) : srng.uniform(0, 0.02);
  const double droop_tau_s = srng.uniform(0.1, 0.4);
  const double ground_max_kmh = heavy ? 90 : 130;
  for (int i = 0; i < n_runs; ++i) {
    RunCase r = base;
    r.seed = seed * 31 + static_cast<std::uint64_t>(i);
    const double spread = (i + srng.uniform()) / n_runs;  // stratified over the runs
    if (!every && bench == can::BenchKind::Roller) {
      r.speed_kmh = rng.uniform(4.5, 5.5);
      r.ramp_bar_per_s =
          std::array{10.0, 25.0, 60.0}[static_cast<std::size_t>(i)] * rng.uniform(0.8, 1.2);
    } else if (!every) {
      r.speed_kmh = std::array{30.0, 50.0, 70.0}[static_cast<std::size_t>(i)];
      r.ramp_bar_per_s = rng.uniform(100, 250);
    } else if (bench == can::BenchKind::Roller) {
      r.speed_kmh = roller_kmh;
      r.ramp_bar_per_s = std::exp(std::log(6.0) + spread * std::log(75.0 / 6.0)) * pressure_scale;
      r.roller_droop_ratio = droop;
      r.roller_droop_ref_n = peak_n;
      r.roller_droop_tau_s = droop_tau_s;
    } else {
      r.speed_kmh = 30 + spread * (ground_max_kmh - 30);
      r.ramp_bar_per_s = srng.uniform(100, 250) * pressure_scale;
    }
    out.runs.push_back(r);
  }
  out.station =
      fmt::format("{} {} runs {:g} Hz {:.1f}-{:.1f} km/h", heavy ? "heavy" : "car", n_runs,
                  tx.sample_hz, out.runs.front().speed_kmh, out.runs.back().speed_kmh);
  if (bench == can::BenchKind::Ground)
    out.station += base.pitch_hz > 0 ? fmt::format(", pitch mode {:.2f} Hz damping {:.2f}",
                                                   base.pitch_hz, base.pitch_damping)
                                     : fmt::format(", pitch lag {:.3f} s", base.pitch_lag_s);
  return out;
}

SetDraw draw_set(can::BenchKind bench, const std::string& effect, double magnitude,
                 std::uint64_t seed, Stations stations) {
  return draw_set(bench, std::vector<EffectDraw>{{effect, magnitude}}, seed, stations);
}

}  // namespace brakefit::sim2
