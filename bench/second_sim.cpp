// Writes one set of generator B's runs (sim/second, the second physics written apart) as event
// CSVs, the tester's export, for `brakefit gap` or anyone else's tool:
//   second_sim --bench roller|ground --effect none|relaxation_length|... [--magnitude X]
//              [--effect2 E --magnitude2 X]   (a second effect in the same set: a pair)
//              [--seed N] [--ripple R] [--speed-step MPS] [--pressure-filter S]
//              [--pressure-step BAR] [--pressure-noise BAR] [--jitter RATIO] [--ripple-ref R]
//              [--pitch-lag S | --pitch-hz F [--pitch-damping Z]] [--truth-curve FILE]
//              [--stations cars|every] --out DIR
// --stations every draws from every export stations make (50-1000 Hz, 2-6 runs, 2-6 km/h rollers
// that droop, heavy vehicles, ground runs at 30-130 km/h); cars (the default) as the referee's
// first draws. The optional overrides replace the drawn tester export (R: both encoders' relative
// ripple) or the drawn body pitch (a lag, or a damped mode of F Hz). Prints the drawn tyre, the
// truth magnitude and the files written. --truth-curve writes the tyre's steady-state curve at the
// set's load and pressure (slip,force_n, slip 0 to 1): what a fit on the tyre's basis should find,
// with the instrument's effects undone.
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "sim/second/generator.hpp"

using namespace brakefit;

int main(int argc, char** argv) {
  std::string bench = "roller", effect = "none", effect2, out, truth_curve, stations = "cars";
  double magnitude = 0, magnitude2 = 0;
  std::uint64_t seed = 1;
  double ripple = -1, speed_step = -1, pressure_filter = -1, pressure_step = -1, jitter = -1,
         ripple_ref = -1, pressure_noise = -1, pitch_lag = -1, pitch_hz = -1,
         pitch_damping = -1;  // < 0: as drawn
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--bench")
      bench = v;
    else if (k == "--effect")
      effect = v;
    else if (k == "--magnitude")
      magnitude = std::atof(v.c_str());
    else if (k == "--effect2")
      effect2 = v;
    else if (k == "--magnitude2")
      magnitude2 = std::atof(v.c_str());
    else if (k == "--seed")
      seed = std::strtoull(v.c_str(), nullptr, 10);
    else if (k == "--ripple")
      ripple = std::atof(v.c_str());
    else if (k == "--speed-step")
      speed_step = std::atof(v.c_str());
    else if (k == "--pressure-filter")
      pressure_filter = std::atof(v.c_str());
    else if (k == "--pressure-step")
      pressure_step = std::atof(v.c_str());
    else if (k == "--pressure-noise")
      pressure_noise = std::atof(v.c_str());
    else if (k == "--ripple-ref")
      ripple_ref = std::atof(v.c_str());
    else if (k == "--jitter")
      jitter = std::atof(v.c_str());
    else if (k == "--out")
      out = v;
    else if (k == "--pitch-lag")
      pitch_lag = std::atof(v.c_str());
    else if (k == "--pitch-hz")
      pitch_hz = std::atof(v.c_str());
    else if (k == "--pitch-damping")
      pitch_damping = std::atof(v.c_str());
    else if (k == "--stations")
      stations = v;
    else if (k == "--truth-curve")
      truth_curve = v;
    else {
      std::cerr << "second_sim: unknown option " << k << "\n";
      return 64;
    }
  }
  if (out.empty() || (bench != "roller" && bench != "ground") ||
      (stations != "cars" && stations != "every")) {
    std::cerr << "second_sim: --bench roller|ground and --out DIR are required; --stations is "
                 "cars or every\n";
    return 64;
  }
  try {
    std::vector<sim2::EffectDraw> effects{{effect, magnitude}};
    if (!effect2.empty()) effects.push_back({effect2, magnitude2});
    auto set =
        sim2::draw_set(bench == "roller" ? can::BenchKind::Roller : can::BenchKind::Ground, effects,
                       seed, stations == "every" ? sim2::Stations::Every : sim2::Stations::Cars);
    for (auto& r : set.runs) {
      if (ripple >= 0) r.tester.eccentricity_ref = r.tester.eccentricity_wheel = ripple;
      if (speed_step >= 0) r.tester.speed_step_mps = speed_step;
      if (pressure_filter >= 0) r.tester.pressure_filter_s = pressure_filter;
      if (ripple_ref >= 0) r.tester.eccentricity_ref = ripple_ref;
      if (pressure_step >= 0) r.tester.pressure_step_bar = pressure_step;
      if (jitter >= 0) r.tester.jitter_ratio = jitter;
      if (pressure_noise >= 0) r.tester.pressure_noise_bar = pressure_noise;
      if (pitch_lag >= 0) {
        r.pitch_lag_s = pitch_lag;
        r.pitch_hz = 0;
      }
      if (pitch_hz >= 0) {
        r.pitch_hz = pitch_hz;
        r.pitch_lag_s = 0;
      }
      if (pitch_damping >= 0) r.pitch_damping = pitch_damping;
    }
    std::filesystem::create_directories(out);
    std::cout << fmt::format("tyre {} Fz {:.0f} N, {:.2f} bar; effect {} magnitude {:.4g}\n",
                             set.runs.front().tyre.name, set.runs.front().fz_n,
                             set.runs.front().pressure_pa / 1e5, effect, set.magnitude);
    if (!effect2.empty())
      std::cout << fmt::format("second effect {} magnitude {:.4g}\n", effect2,
                               set.magnitudes.back());
    std::cout << "station: " << set.station << "\n";
    if (const auto& r = set.runs.front(); bench == "roller" && r.roller_droop_ratio > 0)
      std::cout << fmt::format(
          "roller drive (given): droops {:.2f} % at {:.0f} N behind {:.3f} s\n",
          100 * r.roller_droop_ratio, r.roller_droop_ref_n, r.roller_droop_tau_s);
    if (bench == "ground" && (pitch_lag >= 0 || pitch_hz >= 0 || pitch_damping >= 0)) {
      const auto& r = set.runs.front();
      std::cout << (r.pitch_hz > 0 ? fmt::format("pitch (given): mode {:g} Hz damping {:g}\n",
                                                 r.pitch_hz, r.pitch_damping)
                                   : fmt::format("pitch (given): lag {:g} s\n", r.pitch_lag_s));
    }
    const auto& tx = set.runs.front().tester;
    std::cout << fmt::format(
        "export: speed step {:.2g} m/s, ripple wheel {:.2g} reference {:.2g}, pressure filter "
        "{:.3g} s, {} Hz\n",
        tx.speed_step_mps, tx.eccentricity_wheel, tx.eccentricity_ref, tx.pressure_filter_s,
        tx.sample_hz);
    if (!truth_curve.empty()) {
      const auto& r = set.runs.front();
      sim2::Contact contact;
      contact.fz_n = r.fz_n;
      contact.pressure_pa = r.pressure_pa;
      std::ofstream f(truth_curve);
      f << "slip,force_n\n";
      for (int i = 0; i <= 1000; ++i)
        f << fmt::format("{:.3f},{:.6g}\n", i / 1000.0,
                         sim2::mf61_braking_force_n(r.tyre, i / 1000.0, contact));
    }
    for (std::size_t k = 0; k < set.runs.size(); ++k) {
      const std::string path = fmt::format("{}/{}-{}-{}.csv", out, bench, effect, k);
      std::ofstream(path) << sim2::simulate_event_csv(set.runs[k]);
      std::cout << path << "\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "second_sim: " << e.what() << "\n";
    return 70;
  }
  return 0;
}
