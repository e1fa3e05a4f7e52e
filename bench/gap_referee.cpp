// The blinded-injection referee of `brakefit gap` (issues 5 and 10):
//   gap_referee [--condition roller|ground|roller_vs_road|all] [--trials 200] [--trials-other 80]
//               [--null-share 0.3] [--calibrate 30] [--misspecified 30] [--seed 1] [--threads N]
//               [--generators A,B,C] [--gen-c SCRIPT] [--trials-from C] [--crossed 1]
//               [--only EFFECT,...] [--why 1|2] [--pairs N] [--detection SETS]
//               [--results FILE [--results-key K]]
// Three generators make the runs: A, the project's simulator (candump logs), B, the second
// physics written apart (sim/second: MF 6.1 .tir tyres and a brush family, its own integrator, a
// tester's event-CSV export), and C, a physics written outside the project (--gen-c, by default
// ../shared/gapgen/gen_c.py beside the source tree; roller and ground conditions, its own
// effects and magnitude ranges, its Burckhardt tyre as the misspecified sets). For each condition
// (model vs measurement on the roller and on flat ground; roller vs road, A only): 1. calibrates
// the acceptance gates on null sets of each generator (seeds 1 000 000 + i, disjoint from the
// trials'), 2. runs the trials of each generator with its own gates (straight) and with the other's
// (crossed): each draws an effect or none and a magnitude, simulates three runs, hides the label,
// diagnoses and scores. Prints the confusion matrix, the false-positive rate on none, the share of
// null sets said exactly
// ["none"], the magnitude errors and the gap left after correction relative to the noise floor;
// a JSON document (brakefit.gap_referee/1) last. Trials run on --threads threads (results do not
// depend on it: each trial has its seed).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "bench/outside_generator.hpp"
#include "bench/referee_detection.hpp"
#include "bench/referee_pairs.hpp"
#include "bench/referee_results.hpp"
#include "bench/referee_util.hpp"
#include "brakefit/version.hpp"
#include "sim/referee.hpp"

using namespace brakefit;

namespace {

int g_threads = 2;

using bench::quantile;

struct Settings {
  int trials = 200, trials_other = 80, calib = 30, misspecified = 30;
  int pairs = 0;  ///< --pairs: pair trials per row (A and B, roller and ground)
  int detection = 0, detection_levels = 6;  ///< --detection: sets per magnitude (straight rows)
  double null_share = 0.3;
  std::uint64_t seed = 1;
  std::vector<std::string> only;  ///< --only: run just the trials drawing these effects
  int why = 0;  ///< --why 1: each miss's diagnosis notes on stderr; 2: also each hit, one line
};

/// The calibration's null sets: seeds from here on, disjoint from the trials'.
constexpr std::uint64_t kCalibrationSeed0 = 1'000'000;

/// The gates calibrated on null sets of one generator (from kCalibrationSeed0).
sim::GateCalibration calibrate(gap::Condition c, const Settings& st, sim::Generator gen) {
  const std::string cname = fmt::format("{} {}", gap::to_string(c), sim::to_string(gen));
  std::cerr << fmt::format("[{}] calibrating the gates on {} null sets...\n", cname, st.calib);
  sim::GateCalibration gates;
  std::vector<std::uint64_t> seeds;  // of the null sets scored
  {
    // calibrate_gates is sequential; split its null sets over the threads by hand.
    const auto per = bench::parallel_map<sim::GateCalibration>(
        st.calib, g_threads,
        [&](int i) {
          return sim::calibrate_gates(c, 1, kCalibrationSeed0 + static_cast<std::uint64_t>(i),
                                      gap::Options{}, gen);
        },
        cname + " null sets");
    for (std::size_t i = 0; i < per.size(); ++i) {
      const auto& g = per[i];
      if (g.null_best_gain.empty()) {  // refused: too few usable runs
        ++gates.refused;
        std::cerr << fmt::format("[{}] null set of seed {} refused by the diagnosis\n", cname,
                                 kCalibrationSeed0 + i);
        continue;
      }
      seeds.push_back(kCalibrationSeed0 + i);
      gates.null_best_gain.push_back(g.null_best_gain.front());
      gates.null_best_delta_bic.push_back(g.null_best_delta_bic.front());
      gates.null_gap_over_floor.push_back(g.null_gap_over_floor.front());
    }
    sim::set_gates(gates);
  }
  if (gates.null_best_gain.empty())
    throw std::runtime_error(fmt::format("{}: every null set was refused", cname));
  const auto largest = std::max_element(gates.null_best_gain.begin(), gates.null_best_gain.end());
  std::cerr << fmt::format("[{}] the largest null gain is the null set of seed {}\n", cname,
                           seeds[static_cast<std::size_t>(largest - gates.null_best_gain.begin())]);
  std::cerr << fmt::format(
      "[{}] null best-candidate gain: median {:.3f}, max {:.3f}; best dBIC min {:.1f}; gates: "
      "gain >= {:.3f}, dBIC <= -{:.1f} (shipped: {:.3f}, -{:.1f}); null gap / floor: median "
      "{:.2f}, max {:.2f}, fit-quality factor {:.2f}\n",
      cname, quantile(gates.null_best_gain, 0.5), quantile(gates.null_best_gain, 1.0),
      quantile(gates.null_best_delta_bic, 0.0), gates.options.gate_gain, gates.options.bic_margin,
      gap::calibrated_options(c).gate_gain, gap::calibrated_options(c).bic_margin,
      quantile(gates.null_gap_over_floor, 0.5), quantile(gates.null_gap_over_floor, 1.0),
      gates.options.noise_factor);
  return gates;
}

/// Trials from trial_gen diagnosed with gates calibrated on gate_gen (crossed when they differ).
nlohmann::ordered_json run_condition(gap::Condition c, const Settings& st, sim::Generator trial_gen,
                                     const sim::GateCalibration& gates, sim::Generator gate_gen) {
  const std::string cname =
      fmt::format("{}, trials {}, gates {}{}", gap::to_string(c), sim::to_string(trial_gen),
                  sim::to_string(gate_gen), trial_gen == gate_gen ? "" : " (crossed)");
  const int trials = c == gap::Condition::Roller ? st.trials : st.trials_other;
  // Draws first (one generator, in order), then the trials in parallel.
  Rng rng(st.seed + 100 * static_cast<std::uint64_t>(c));
  std::vector<sim::Injection> draws;
  draws.reserve(static_cast<std::size_t>(std::max(0, trials)));
  for (int t = 0; t < trials; ++t)
    draws.push_back(sim::draw_injection(rng, st.null_share, c, trial_gen));
  // --only: the same draws and seeds as the whole run, the other effects' trials left out.
  std::vector<int> kept;
  for (int t = 0; t < trials; ++t)
    if (st.only.empty() || std::find(st.only.begin(), st.only.end(),
                                     draws[static_cast<std::size_t>(t)].effect) != st.only.end())
      kept.push_back(t);
  const auto results = bench::parallel_map<sim::TrialResult>(
      static_cast<int>(kept.size()), g_threads,
      [&](int k) {
        const int t = kept[static_cast<std::size_t>(k)];
        return sim::run_trial(draws[static_cast<std::size_t>(t)],
                              st.seed * 1000 + static_cast<std::uint64_t>(t) +
                                  100'000 * static_cast<std::uint64_t>(c),
                              gates.options);
      },
      cname + " trials");

  std::vector<std::string> labels{"none"};
  for (const auto& e : sim::referee_effects(c, trial_gen)) labels.push_back(e);
  std::map<std::string, std::map<std::string, int>> confusion;
  // mag_err: every trial whose report scored the effect (named or not); mag_err_named: the trials
  // that name it, where the diagnosis claims the magnitude.
  std::map<std::string, std::vector<double>> mag_err, mag_err_named, after_by_effect;
  std::vector<double> after_over_noise;
  std::vector<double> load_ratio_err;  // load transfer as dFz/Fz per m/s^2, where named
  std::map<std::string, std::pair<int, int>> by_vehicle;  // right (named or none), all
  int correct_effects = 0, exact_effects = 0, n_effects = 0, n_none = 0, fp_none = 0,
      none_exact = 0, refused = 0;
  for (std::size_t k = 0; k < results.size(); ++k) {
    const auto& r = results[k];
    const auto& inj = r.truth;
    const std::string said = r.verdict.empty() ? "?" : r.verdict.front();
    ++confusion[inj.effect][said];
    const double floor_n = std::max(r.noise_n, 1e-9);
    const double ratio = r.gap_after_n / floor_n, before_ratio = r.gap_before_n / floor_n;
    // Every miss, to be looked at one by one (trial index: --only keeps it); --why 2: the hits
    // too, with their estimate and the gap left.
    if (!r.exact() || st.why > 1)
      std::cerr << fmt::format(
          "[{}] trial {}: {} {:.4g} said {}{}{}\n", cname, kept[k], inj.effect, inj.magnitude,
          fmt::join(r.verdict, ", "), inj.station.empty() ? "" : " [" + inj.station + "]",
          r.exact() ? fmt::format(" (estimate {:.4g}, gap after / floor {:.2f}, before {:.2f})",
                                  r.estimate, ratio, before_ratio)
                    : fmt::format(" (gap before / floor {:.2f})", before_ratio));
    if (!r.exact() && st.why)
      for (const auto& n : r.notes) std::cerr << "    " << n << "\n";
    if (said == "refused") {
      ++refused;
      std::cerr << fmt::format("[{}] refused ({} {}): {}\n", cname, inj.effect, inj.magnitude,
                               r.notes.empty() ? "" : r.notes.front());
    }
    if (!inj.station.empty()) {  // by vehicle: the first word of the station drawn
      auto& [right, all] = by_vehicle[inj.station.substr(0, inj.station.find(' '))];
      right += r.exact() || (inj.effect != "none" && r.correct());
      ++all;
    }
    if (inj.effect == "none") {
      ++n_none;
      after_by_effect["none"].push_back(ratio);  // the null's own gap / floor: the floor's honesty
      if (said != "none" && said != "unexplained" && said != "refused") ++fp_none;
      if (r.exact()) ++none_exact;
      continue;
    }
    ++n_effects;
    if (r.correct()) ++correct_effects;
    if (r.exact()) ++exact_effects;
    if (std::isfinite(r.estimate)) {
      const double err = std::abs(r.estimate - inj.magnitude) / std::abs(inj.magnitude);
      mag_err[inj.effect].push_back(err);
      if (std::find(r.verdict.begin(), r.verdict.end(), inj.effect) != r.verdict.end())
        mag_err_named[inj.effect].push_back(err);
    }
    if (r.correct()) after_over_noise.push_back(ratio);
    if (std::isfinite(r.load_per_decel_estimate) && std::isfinite(inj.load_per_decel))
      load_ratio_err.push_back(std::abs(r.load_per_decel_estimate / inj.load_per_decel - 1));
    after_by_effect[inj.effect].push_back(ratio);
  }
  std::vector<std::string> said_cols = labels;
  said_cols.push_back("unexplained");
  std::cout << fmt::format("\n## {}: {} trials, {} null\n\n", cname, results.size(), n_none);
  std::cout << fmt::format("| injected \\ said | {} |\n|---|{}\n", fmt::join(said_cols, " | "),
                           std::string(said_cols.size() * 4, '-') + "|");
  for (const auto& l : labels) {
    std::cout << "| " << l;
    for (const auto& col : said_cols) std::cout << " | " << confusion[l][col];
    std::vector<std::string> other;
    for (const auto& [k, v] : confusion[l])
      if (std::find(said_cols.begin(), said_cols.end(), k) == said_cols.end())
        other.push_back(fmt::format("{} {}", k, v));
    std::cout << (other.empty() ? "" : fmt::format(" (+{})", fmt::join(other, ", "))) << " |\n";
  }
  for (const auto& [vehicle, counts] : by_vehicle)
    std::cout << fmt::format("{} sets: {} of {} right (the effect named, or none for none)\n",
                             vehicle, counts.first, counts.second);
  nlohmann::ordered_json j;
  j["condition"] = gap::to_string(c);
  for (const auto& [vehicle, counts] : by_vehicle)
    j["by_vehicle"][vehicle] = {{"right", counts.first}, {"sets", counts.second}};
  j["trial_generator"] = sim::to_string(trial_gen);
  j["gate_generator"] = sim::to_string(gate_gen);
  j["crossed"] = trial_gen != gate_gen;
  j["trials"] = results.size();
  j["null_trials"] = n_none;
  j["gate_gain"] = gates.options.gate_gain;
  j["bic_margin"] = gates.options.bic_margin;
  j["null_best_gain_max"] = quantile(gates.null_best_gain, 1.0);
  j["null_best_delta_bic_min"] = quantile(gates.null_best_delta_bic, 0.0);
  j["accuracy_effects"] = n_effects ? static_cast<double>(correct_effects) / n_effects : NAN;
  j["accuracy_effects_exact"] = n_effects ? static_cast<double>(exact_effects) / n_effects : NAN;
  j["false_positive_rate_none"] = n_none ? static_cast<double>(fp_none) / n_none : NAN;
  j["null_exactly_none"] = n_none ? static_cast<double>(none_exact) / n_none : NAN;
  j["refused"] = refused;
  j["counts"] = {{"effects", n_effects}, {"correct", correct_effects}, {"exact", exact_effects},
                 {"null", n_none},       {"false_positives", fp_none}, {"null_none", none_exact},
                 {"refused", refused}};
  std::cout << fmt::format(
      "\neffects correct: {}/{} ({:.1f} %; first verdict exactly the injected effect: {:.1f} %), "
      "false positives on none: {}/{} ({:.1f} %), null sets exactly [\"none\"]: {}/{}, sets "
      "refused: {}\n",
      correct_effects, n_effects, 100.0 * correct_effects / std::max(1, n_effects),
      100.0 * exact_effects / std::max(1, n_effects), fp_none, n_none,
      100.0 * fp_none / std::max(1, n_none), none_exact, n_none, refused);
  for (const auto& [e, v] : mag_err) {
    const auto within = std::count_if(v.begin(), v.end(), [](double x) { return x <= 0.25; });
    const double share = static_cast<double>(within) / static_cast<double>(v.size());
    j["magnitude_error"][e] = {
        {"median", quantile(v, 0.5)}, {"p90", quantile(v, 0.9)}, {"within_25pct", share}};
    std::cout << fmt::format(
        "magnitude error, {}: median {:.1f} %, p90 {:.1f} %, within 25 %: {:.0f} %\n", e,
        100 * quantile(v, 0.5), 100 * quantile(v, 0.9), 100 * share);
  }
  for (const auto& [e, v] : mag_err_named) {
    j["magnitude_error_named"][e] = {
        {"median", quantile(v, 0.5)}, {"p90", quantile(v, 0.9)}, {"trials", v.size()}};
    std::cout << fmt::format(
        "magnitude error where named, {}: median {:.1f} %, p90 {:.1f} % ({} trials)\n", e,
        100 * quantile(v, 0.5), 100 * quantile(v, 0.9), v.size());
  }
  if (!load_ratio_err.empty()) {
    j["load_ratio_error_named"] = {{"median", quantile(load_ratio_err, 0.5)},
                                   {"p90", quantile(load_ratio_err, 0.9)},
                                   {"trials", load_ratio_err.size()}};
    std::cout << fmt::format(
        "load transfer as dFz/Fz per m/s^2 where named: median {:.1f} %, p90 {:.1f} % ({} "
        "trials)\n",
        100 * quantile(load_ratio_err, 0.5), 100 * quantile(load_ratio_err, 0.9),
        load_ratio_err.size());
  }
  j["gap_after_over_noise"] = {{"median", quantile(after_over_noise, 0.5)},
                               {"p90", quantile(after_over_noise, 0.9)}};
  std::cout << fmt::format("gap after / noise (correct trials): median {:.2f}, p90 {:.2f}\n",
                           quantile(after_over_noise, 0.5), quantile(after_over_noise, 0.9));
  for (const auto& [e, v] : after_by_effect) {
    std::cout << fmt::format("gap after / noise, {}: median {:.2f}, p90 {:.2f} ({} trials)\n", e,
                             quantile(v, 0.5), quantile(v, 0.9), v.size());
    j["gap_after_over_noise_by_effect"][e] = {{"median", quantile(v, 0.5)},
                                              {"p90", quantile(v, 0.9)}};
  }
  if (st.misspecified > 0) {
    // Misspecified tyre family (Burckhardt curve, no effect): must give none or unexplained.
    const auto mis = bench::parallel_map<sim::TrialResult>(
        st.misspecified, g_threads,
        [&](int t) {
          sim::Injection inj;
          inj.effect = "misspecified";
          inj.condition = c;
          inj.generator = trial_gen;
          return sim::run_trial(inj, 500'000 + static_cast<std::uint64_t>(t), gates.options);
        },
        "misspecified");
    int ok = 0;
    std::map<std::string, int> said;
    for (const auto& r : mis) {
      ++said[r.verdict.empty() ? "?" : r.verdict.front()];
      ok += r.correct();
    }
    j["misspecified_trials"] = st.misspecified;
    j["misspecified_none_or_unexplained"] = static_cast<double>(ok) / st.misspecified;
    j["counts"]["misspecified"] = st.misspecified;
    j["counts"]["misspecified_ok"] = ok;
    j["misspecified_said"] = said;
    std::cout << fmt::format(
        "misspecified tyre (A, C: Burckhardt, B: brush model): none/unexplained in {}/{}; first "
        "verdicts:",
        ok, st.misspecified);
    for (const auto& [k, v] : said) std::cout << fmt::format(" {} {}", k, v);
    std::cout << "\n";
  }
  if (st.pairs > 0 && trial_gen != sim::Generator::C && c != gap::Condition::RollerToRoad)
    j.update(bench::run_pairs(c, trial_gen, gates.options,
                              {st.pairs, st.seed, g_threads, st.why, st.only}, cname),
             /*merge_objects=*/true);
  if (st.detection > 0 && trial_gen == gate_gen && c != gap::Condition::RollerToRoad)
    j.update(bench::run_detection(c, trial_gen, gates.options,
                                  {st.detection, st.detection_levels, g_threads, st.seed}, cname),
             /*merge_objects=*/true);
  return j;
}

int run(int argc, char** argv) {
  const auto started = std::chrono::steady_clock::now();
  const std::string commit = bench::source_commit();
  Settings st;
  std::string which = "all", generators = "A,B";
  std::string gen_c = std::string(BRAKEFIT_SOURCE_DIR) + "/../shared/gapgen/gen_c.py";
  std::string trials_from;           // --trials-from: only these generators' trials (empty: all)
  std::string results, results_key;  // --results FILE [--results-key KEY]
  std::string stations = "cars";     // --stations: generator B's draws
  bool crossed = true;
  g_threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (int i = 1; i < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "-h" || k == "--help" || i + 1 == argc) {
      std::cerr
          << "usage: gap_referee [--condition roller|ground|roller_vs_road|all] [--trials N]\n"
             "  [--trials-other N] [--null-share R] [--calibrate N] [--misspecified N]\n"
             "  [--pairs N]           (pair trials per row: two effects at once, A and B)\n"
             "  [--seed S] [--threads N] [--generators A,B,C] [--gen-c SCRIPT] [--crossed 1|0]\n"
             "  [--trials-from C]      (only these generators' trials; gates from all)\n"
             "  [--stations cars|every] (generator B's sets: cars at 5 km/h and 30-70 km/h, or\n"
             "                         every export: 50-1000 Hz, 2-6 runs, heavy vehicles)\n"
             "  [--only EFFECT,...]   (the trials that draw these effects, e.g. none)\n"
             "  [--detection SETS [--detection-levels L]]  (detection curves: SETS sets at\n"
             "                         each of L magnitudes per effect, straight rows)\n"
             "  [--results FILE [--results-key KEY]]  (the tables into FILE's section KEY,\n"
             "                         by default the condition and generators; the command\n"
             "                         and the commit at its head)\n"
             "  [--why 1|2]           (1: each miss's notes, the misses are always listed;\n"
             "                         2: each hit too, with its estimate and gap left)\n";
      return k == "-h" || k == "--help" ? 0 : 64;
    }
    const char* v = argv[i + 1];
    if (k == "--trials")
      st.trials = std::atoi(v);
    else if (k == "--trials-other")
      st.trials_other = std::atoi(v);
    else if (k == "--calibrate")
      st.calib = std::max(1, std::atoi(v));
    else if (k == "--pairs")
      st.pairs = std::atoi(v);
    else if (k == "--misspecified")
      st.misspecified = std::atoi(v);
    else if (k == "--null-share")
      st.null_share = std::atof(v);
    else if (k == "--seed")
      st.seed = std::strtoull(v, nullptr, 10);
    else if (k == "--threads")
      g_threads = std::atoi(v);
    else if (k == "--condition")
      which = v;
    else if (k == "--generators")
      generators = v;
    else if (k == "--gen-c")
      gen_c = v;
    else if (k == "--detection")
      st.detection = std::atoi(v);
    else if (k == "--detection-levels")
      st.detection_levels = std::max(2, std::atoi(v));
    else if (k == "--results")
      results = v;
    else if (k == "--results-key")
      results_key = v;
    else if (k == "--trials-from")
      trials_from = v;
    else if (k == "--stations")
      stations = v;
    else if (k == "--only") {
      std::stringstream list(v);
      for (std::string e; std::getline(list, e, ',');) st.only.push_back(e);
    } else if (k == "--why")
      st.why = std::atoi(v);
    else if (k == "--crossed")
      crossed = std::string(v) != "0" && std::string(v) != "no";
    else {
      std::cerr << "gap_referee: unknown option " << k << "\n";
      return 64;
    }
  }
  if (stations != "cars" && stations != "every") {
    std::cerr << "gap_referee: --stations is cars or every\n";
    return 64;
  }
  sim::set_generator_b_stations(stations == "every" ? sim2::Stations::Every : sim2::Stations::Cars);
  if (!results.empty() && !std::ofstream(results, std::ios::app)) {  // before hours of trials
    std::cerr << "gap_referee: cannot write the results file " << results << "\n";
    return 73;
  }
  if (generators.find('C') != std::string::npos) {
    if (!std::filesystem::exists(gen_c)) {
      std::cerr << "gap_referee: generator C's script " << gen_c << " is not there (--gen-c)\n";
      return 66;
    }
    sim::set_outside_runs([gen_c](sim::Injection& inj, std::uint64_t seed) {
      return bench::outside_runs(gen_c, inj, seed);
    });
  }
  nlohmann::ordered_json j;
  j["schema"] = "brakefit.gap_referee/1";
  j["version"] = kVersion;
  j["seed"] = st.seed;
  j["stations"] = stations;
  bool any = false;
  for (auto c : {gap::Condition::Roller, gap::Condition::Ground, gap::Condition::RollerToRoad}) {
    if (which != "all" && which != gap::to_string(c)) continue;
    any = true;
    // Generators B and C make model-vs-measurement runs only; roller vs road stays A's.
    std::vector<sim::Generator> gens;
    for (auto g : {sim::Generator::A, sim::Generator::B, sim::Generator::C})
      if (generators.find(sim::to_string(g)) != std::string::npos &&
          (g == sim::Generator::A || c != gap::Condition::RollerToRoad))
        gens.push_back(g);
    std::map<sim::Generator, sim::GateCalibration> gates;
    for (auto g : gens) gates[g] = calibrate(c, st, g);
    // Straight (trials and gates of one generator), then crossed (gates of the other).
    for (auto trial : gens)
      for (auto gate : gens)
        if ((gate == trial || crossed) &&
            (trials_from.empty() || trials_from.find(sim::to_string(trial)) != std::string::npos))
          j["conditions"].push_back(run_condition(c, st, trial, gates[gate], gate));
  }
  if (!any) {
    std::cerr << "gap_referee: --condition must be roller, ground, roller_vs_road or all\n";
    return 64;
  }
  std::cout << "\n" << j.dump() << "\n";
  if (!results.empty()) {
    std::string command;
    for (int i = 0; i < argc; ++i) command += (i ? " " : "") + std::string(argv[i]);
    const double minutes =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count() / 60;
    bench::write_results_section(
        results, results_key.empty() ? fmt::format("{} {}", which, generators) : results_key,
        command, commit, minutes, bench::results_markdown(j));
    std::cerr << "gap_referee: the tables are in " << results << "\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "gap_referee: " << e.what() << "\n";
    return 70;
  }
}
