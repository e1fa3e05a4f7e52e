#include "bench/referee_condition.hpp"

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
#include "bench/referee_outside.hpp"
#include "bench/referee_pairs.hpp"
#include "bench/referee_results.hpp"
#include "bench/referee_util.hpp"
#include "sim/referee.hpp"

namespace brakefit::bench {

namespace {

/// The calibration's null sets: seeds from here on, disjoint from the trials'.
constexpr std::uint64_t kCalibrationSeed0 = 1'000'000;

}  // namespace

sim::GateCalibration calibrate(gap::Condition c, const Settings& st, sim::Generator gen) {
  const std::string cname = fmt::format("{} {}", gap::to_string(c), sim::to_string(gen));
  std::cerr << fmt::format("[{}] calibrating the gates on {} null sets...\n", cname, st.calib);
  sim::GateCalibration gates;
  std::vector<std::uint64_t> seeds;  // of the null sets scored
  {
    // calibrate_gates is sequential; split its null sets over the threads by hand.
    const auto per = parallel_map<sim::GateCalibration>(
        st.calib, st.threads,
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
      gates.null_points.push_back(g.null_points.front());
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
      "gain >= {:.3f}, dBIC <= -max({:.1f}, {:.4f} per point) (shipped: {:.3f}, -{:.1f}); null "
      "gap / floor: median {:.2f}, max {:.2f}, fit-quality factor {:.2f}\n",
      cname, quantile(gates.null_best_gain, 0.5), quantile(gates.null_best_gain, 1.0),
      quantile(gates.null_best_delta_bic, 0.0), gates.options.gate_gain, gates.options.bic_margin,
      gates.options.bic_margin_per_point, gap::calibrated_options(c).gate_gain,
      gap::calibrated_options(c).bic_margin, quantile(gates.null_gap_over_floor, 0.5),
      quantile(gates.null_gap_over_floor, 1.0), gates.options.noise_factor);
  return gates;
}

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
  // --only, --pick: the same draws and seeds as the whole run, the other trials left out.
  std::vector<int> kept;
  for (int t = 0; t < trials; ++t)
    if ((st.only.empty() ||
         std::find(st.only.begin(), st.only.end(), draws[static_cast<std::size_t>(t)].effect) !=
             st.only.end()) &&
        (st.pick.empty() || std::find(st.pick.begin(), st.pick.end(), t) != st.pick.end()))
      kept.push_back(t);
  const auto results = parallel_map<sim::TrialResult>(
      static_cast<int>(kept.size()), st.threads,
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
  // Of those read at published tyres' laws, the truths inside the band their ends give.
  int load_band_inside = 0, load_band_of = 0;
  std::map<std::string, std::pair<int, int>> by_vehicle;  // right (named or none), all
  int correct_effects = 0, exact_effects = 0, n_effects = 0, n_none = 0, fp_none = 0,
      none_exact = 0, refused = 0;
  // Each effect's misses, and how many of those sets' runs could not have shown it (the truth
  // below the smallest magnitude the report says they could show).
  struct Missed {
    int sets = 0, with_reach = 0, below_reach = 0;
  };
  std::map<std::string, Missed> missed;  // load transfer and a cradle cap have no reach
  for (std::size_t k = 0; k < results.size(); ++k) {
    const auto& r = results[k];
    const auto& inj = r.truth;
    const std::string said = r.verdict.empty() ? "?" : r.verdict.front();
    ++confusion[inj.effect][said];
    if (inj.effect != "none" && !r.correct()) {
      Missed& m = missed[inj.effect];
      ++m.sets;
      if (!std::isnan(r.reach)) ++m.with_reach;
      if (std::abs(inj.magnitude) < r.reach) ++m.below_reach;
    }
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
    if ((!r.exact() && st.why) || st.why > 1) {
      print_indented(r.notes);
      print_indented(r.scores);
    }
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
    if (std::isfinite(r.load_per_decel_low) && std::isfinite(r.load_per_decel_high) &&
        std::isfinite(inj.load_per_decel)) {
      ++load_band_of;
      load_band_inside +=
          r.load_per_decel_low <= inj.load_per_decel && inj.load_per_decel <= r.load_per_decel_high;
    }
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
  j["bic_margin_per_point"] = gates.options.bic_margin_per_point;
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
  if (load_band_of > 0) {
    j["load_ratio_inside_published_band"] = {{"inside", load_band_inside}, {"of", load_band_of}};
    std::cout << fmt::format(
        "load transfer's truth inside the band at the ends of published tyres' laws: {} of {}\n",
        load_band_inside, load_band_of);
  }
  for (const auto& [e, m] : missed) {
    j["missed"][e] = {
        {"sets", m.sets}, {"with_reach", m.with_reach}, {"below_reach", m.below_reach}};
    std::cout << fmt::format(
        "{} missed in {} sets, {} of them below the smallest magnitude their runs could show{}\n",
        e, m.sets, m.below_reach,
        m.with_reach < m.sets ? fmt::format(" ({} without a reach)", m.sets - m.with_reach) : "");
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
    const auto mis = parallel_map<sim::TrialResult>(
        st.misspecified, st.threads,
        [&](int t) {
          sim::Injection inj;
          inj.effect = "misspecified";
          inj.condition = c;
          inj.generator = trial_gen;
          return sim::run_trial(inj, sim::misspecified_seed(static_cast<std::uint64_t>(t)),
                                gates.options);
        },
        "misspecified");
    int ok = 0;
    std::map<std::string, int> said;
    for (std::size_t k = 0; k < mis.size(); ++k) {
      const auto& r = mis[k];
      ++said[r.verdict.empty() ? "?" : r.verdict.front()];
      ok += r.correct();
      // A claim on a tyre that is not a Magic Formula, to be looked at (--why: its notes).
      if (!r.correct() && st.why) {
        std::cerr << fmt::format("[{}] misspecified {} said {} (gap before / floor {:.2f})\n",
                                 cname, k, fmt::join(r.verdict, ", "),
                                 r.gap_before_n / std::max(r.noise_n, 1e-9));
        print_indented(r.notes);
        if (st.why > 1) print_indented(r.scores);
      }
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
  if (st.outside > 0)
    j.update(run_outside(c, trial_gen, gates.options, {st.outside, st.threads, st.why}, cname),
             /*merge_objects=*/true);
  if (st.pairs > 0 && !sim::draws_pairs(c, trial_gen))
    std::cout << fmt::format("\npairs: generator {} draws none in {}\n", sim::to_string(trial_gen),
                             gap::to_string(c));
  else if (st.pairs > 0)
    j.update(run_pairs(c, trial_gen, gates.options,
                       {st.pairs, st.seed, st.threads, st.why, st.only, st.pick}, cname),
             /*merge_objects=*/true);
  if (st.detection > 0 && trial_gen == gate_gen && c != gap::Condition::RollerToRoad)
    j.update(run_detection(
                 c, trial_gen, gates.options,
                 {st.detection, st.detection_levels, st.threads, st.seed, st.why, st.only}, cname),
             /*merge_objects=*/true);
  return j;
}

}  // namespace brakefit::bench
