// The blinded-injection referee of `brakefit gap` (issues 5 and 10):
//   gap_referee [--condition roller|ground|roller_vs_road|all] [--trials 200] [--trials-other 80]
//               [--null-share 0.3] [--calibrate 30] [--misspecified 30] [--seed 1] [--threads N]
//               [--generators A,B,C] [--gen-c SCRIPT] [--trials-from C] [--crossed 1|0|only]
//               [--only EFFECT,...] [--pick I,...] [--why 1|2] [--pairs N] [--detection SETS]
//               [--results FILE [--results-key K]] [--export-hz HZ] [--outside N] [--tyre-file]
//               [--realign 1] [--dry-run 1]
// Three generators make the runs: A, the project's simulator (candump logs), B, the second
// physics written apart (sim/second: MF 6.1 .tir tyres and a brush family, its own integrator, a
// tester's event-CSV export), and C, a physics written outside the project (--gen-c, by default
// ../shared/gapgen/gen_c.py beside the source tree; roller and ground conditions, its own
// effects and magnitude ranges, its Burckhardt tyre as the misspecified sets). For each condition
// (model vs measurement on the roller and on flat ground; roller vs road, A only): 1. calibrates
// the acceptance gates on null sets of each generator (seeds 1 000 000 + i, disjoint from the
// trials'), 2. runs the trials of each generator with its own gates (straight) and with the other's
// (crossed; `--crossed only`: those rows alone): each draws an effect or none and a magnitude,
// simulates three runs, hides the label, diagnoses and scores. Prints the confusion matrix, the
// false-positive rate on none, the share of null sets said exactly
// ["none"], the magnitude errors and the gap left after correction relative to the noise floor;
// a JSON document (brakefit.gap_referee/1) last. Trials run on --threads threads (results do not
// depend on it: each trial has its seed).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cerrno>
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
#include <stdexcept>
#include <thread>

#include "bench/outside_generator.hpp"
#include "bench/referee_condition.hpp"
#include "bench/referee_detection.hpp"
#include "bench/referee_pairs.hpp"
#include "bench/referee_results.hpp"
#include "bench/referee_util.hpp"
#include "brakefit/version.hpp"
#include "sim/referee.hpp"

using namespace brakefit;

namespace {

/// A command line the referee cannot run: said with the option, exit 64.
struct Usage : std::runtime_error {
  using std::runtime_error::runtime_error;
};

int run(int argc, char** argv) {
  const auto started = std::chrono::steady_clock::now();
  const std::string commit = bench::source_commit();
  bench::Settings st;
  std::string which = "all", generators = "A,B";
  std::string gen_c = std::string(BRAKEFIT_SOURCE_DIR) + "/../shared/gapgen/gen_c.py";
  std::string trials_from;           // --trials-from: only these generators' trials (empty: all)
  std::string results, results_key;  // --results FILE [--results-key KEY]
  std::string stations = "cars";     // --stations: generator B's draws
  bool tyre_file = false;  // --tyre-file 1: each diagnosis given its tyre's load laws (gap --tir)
  std::string export_hz_text;  // --export-hz: generator B's export rate (empty: as drawn)
  bool crossed = true, crossed_only = false;  // --crossed 1|0|only
  bool dry_run = false;  // --dry-run 1: the options checked and the rows listed, nothing run
  bool realign =
      false;  // --realign 1: each diagnosis realigns a late channel (gap --realign-delay)
  st.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (int i = 1; i < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "-h" || k == "--help" || i + 1 == argc) {
      std::cerr
          << "usage: gap_referee [--condition roller|ground|roller_vs_road|all] [--trials N]\n"
             "  [--trials-other N] [--null-share R] [--calibrate N] [--misspecified N]\n"
             "  [--pairs N]           (pair trials per row: two effects at once; C's on the\n"
             "                         ground only)\n"
             "  [--outside N]         (A's and B's sets with an effect outside the\n"
             "                         catalogue: a pressure transducer's bow, fading friction)\n"
             "  [--seed S] [--threads N] [--generators A,B,C] [--gen-c SCRIPT]\n"
             "  [--crossed 1|0|only]  (rows with another generator's gates too, or only them)\n"
             "  [--trials-from C]      (only these generators' trials; gates from all)\n"
             "  [--stations cars|every] (generator B's sets: cars at 5 km/h and 30-70 km/h, or\n"
             "                         every export: 50-1000 Hz, 2-6 runs, heavy vehicles)\n"
             "  [--export-hz HZ]      (generator B's sets, gates' and trials', exported at HZ\n"
             "                         instead of their drawn rate: what the rate alone costs)\n"
             "  [--tyre-file 1]       (each diagnosis given its tyre's own load laws, as\n"
             "                         `brakefit gap --tir` its file; default published tyres')\n"
             "  [--only EFFECT,...]   (the trials that draw these effects, e.g. none; the\n"
             "                         detection curves of these effects)\n"
             "  [--pick I,...]        (only these trials and pair trials, by the index a miss "
             "names)\n"
             "  [--detection SETS [--detection-levels L]]  (detection curves: SETS sets at\n"
             "                         each of L magnitudes per effect, straight rows)\n"
             "  [--results FILE [--results-key KEY]]  (the tables into FILE's section KEY,\n"
             "                         by default the condition and generators; the command\n"
             "                         and the commit at its head)\n"
             "  [--why 1|2]           (1: each miss's notes, the misses are always listed;\n"
             "                         2: each hit too, with its estimate, gap left and notes)\n"
             "  [--realign 1]         (each diagnosis reads a late channel at the delay named\n"
             "                         and diagnoses again, as `brakefit gap --realign-delay`)\n"
             "  [--dry-run 1]         (the options checked and the rows listed as JSON; nothing\n"
             "                         calibrated or run)\n";
      return k == "-h" || k == "--help" ? 0 : 64;
    }
    const char* v = argv[i + 1];
    // A count or a share that does not read as one is refused by its option's name: atoi's 0
    // would run a referee of no trials for hours of calibration.
    const auto count = [&](int& out, int at_least) {
      char* end = nullptr;
      errno = 0;
      const long n = std::strtol(v, &end, 10);
      if (end == v || *end != '\0' || errno != 0 || n < at_least || n > 1'000'000)
        throw Usage(fmt::format("{} takes a whole number from {}, not '{}'", k, at_least, v));
      out = static_cast<int>(n);
    };
    if (k == "--trials")
      count(st.trials, 0);
    else if (k == "--trials-other")
      count(st.trials_other, 0);
    else if (k == "--calibrate")
      count(st.calib, 1);
    else if (k == "--pairs")
      count(st.pairs, 0);
    else if (k == "--misspecified")
      count(st.misspecified, 0);
    else if (k == "--outside")
      count(st.outside, 0);
    else if (k == "--null-share") {
      char* end = nullptr;
      st.null_share = std::strtod(v, &end);
      if (end == v || *end != '\0' || !(st.null_share >= 0 && st.null_share <= 1))
        throw Usage(fmt::format("--null-share takes a share from 0 to 1, not '{}'", v));
    } else if (k == "--seed") {
      char* end = nullptr;
      errno = 0;
      st.seed = std::strtoull(v, &end, 10);
      if (end == v || *end != '\0' || errno != 0 || *v == '-')
        throw Usage(fmt::format("--seed takes a whole number, not '{}'", v));
    } else if (k == "--threads")
      count(st.threads, 1);
    else if (k == "--condition")
      which = v;
    else if (k == "--generators")
      generators = v;
    else if (k == "--gen-c")
      gen_c = v;
    else if (k == "--detection")
      count(st.detection, 0);
    else if (k == "--detection-levels") {
      count(st.detection_levels, 2);
    } else if (k == "--results")
      results = v;
    else if (k == "--results-key")
      results_key = v;
    else if (k == "--trials-from")
      trials_from = v;
    else if (k == "--stations")
      stations = v;
    else if (k == "--export-hz")
      export_hz_text = v;
    else if (k == "--realign") {
      const std::string w = v;
      if (w != "1" && w != "0") throw Usage(fmt::format("--realign takes 1 or 0, not '{}'", w));
      realign = w == "1";
    } else if (k == "--dry-run") {
      const std::string w = v;
      if (w != "1" && w != "0") throw Usage(fmt::format("--dry-run takes 1 or 0, not '{}'", w));
      dry_run = w == "1";
    } else if (k == "--tyre-file") {
      const std::string w = v;
      if (w != "1" && w != "0") throw Usage(fmt::format("--tyre-file takes 1 or 0, not '{}'", w));
      tyre_file = w == "1";
    } else if (k == "--only") {
      std::stringstream list(v);
      for (std::string e; std::getline(list, e, ',');) st.only.push_back(e);
    } else if (k == "--pick") {
      std::stringstream list(v);
      for (std::string e; std::getline(list, e, ',');) st.pick.push_back(std::atoi(e.c_str()));
    } else if (k == "--why")
      count(st.why, 0);
    else if (k == "--crossed") {
      const std::string w = v;
      if (w != "1" && w != "yes" && w != "0" && w != "no" && w != "only")
        throw Usage(fmt::format("--crossed takes 1, 0 or only, not '{}'", w));
      crossed = w != "0" && w != "no";
      crossed_only = w == "only";
    } else {
      std::cerr << "gap_referee: unknown option " << k << "\n";
      return 64;
    }
  }
  if (stations != "cars" && stations != "every") {
    std::cerr << "gap_referee: --stations is cars or every\n";
    return 64;
  }
  sim::set_generator_b_stations(stations == "every" ? sim2::Stations::Every : sim2::Stations::Cars);
  // A tester exports at 50 Hz to a few kHz; below 10 Hz a stop holds a sample or two.
  double export_hz = 0;
  if (!export_hz_text.empty()) {
    char* end = nullptr;
    export_hz = std::strtod(export_hz_text.c_str(), &end);
    if (*end != '\0' || !(export_hz >= 10 && export_hz <= 20000)) {
      std::cerr << "gap_referee: --export-hz is a rate from 10 to 20000 Hz, not '" << export_hz_text
                << "'\n";
      return 64;
    }
  }
  sim::set_generator_b_export_hz(export_hz);
  sim::set_tyre_file_known(tyre_file);
  sim::set_realign_late_channel(realign);
  if (!results.empty()) {  // before hours of trials
    const auto dir = std::filesystem::path(results).parent_path();
    if (dry_run ? !std::filesystem::is_directory(dir.empty() ? "." : dir)
                : !std::ofstream(results, std::ios::app)) {
      std::cerr << "gap_referee: cannot write the results file " << results << "\n";
      return 73;
    }
  }
  if (generators.find('C') != std::string::npos) {
    if (!std::filesystem::exists(gen_c)) {
      std::cerr << "gap_referee: generator C's script " << gen_c << " is not there (--gen-c)\n";
      return 66;
    }
    if (const auto missing = bench::outside_generator_missing(); !missing.empty()) {
      std::cerr << "gap_referee: " << missing << "\n";
      return 69;
    }
    sim::set_outside_runs([gen_c](sim::Injection& inj, std::uint64_t seed) {
      return bench::outside_runs(gen_c, inj, seed);
    });
  }
  // The rows: for each condition, straight (trials and gates of one generator), then crossed
  // (gates of another). Generators B and C make model-vs-measurement runs only; roller vs road
  // stays A's.
  struct Row {
    gap::Condition condition;
    sim::Generator trial, gate;
  };
  std::vector<Row> rows;
  std::map<gap::Condition, std::vector<sim::Generator>> calibrated;
  for (auto c : {gap::Condition::Roller, gap::Condition::Ground, gap::Condition::RollerToRoad}) {
    if (which != "all" && which != gap::to_string(c)) continue;
    auto& gens = calibrated[c];
    for (auto g : {sim::Generator::A, sim::Generator::B, sim::Generator::C})
      if (generators.find(sim::to_string(g)) != std::string::npos &&
          (g == sim::Generator::A || c != gap::Condition::RollerToRoad))
        gens.push_back(g);
    for (auto trial : gens)
      for (auto gate : gens)
        if ((gate == trial ? !crossed_only : crossed) &&
            (trials_from.empty() || trials_from.find(sim::to_string(trial)) != std::string::npos))
          rows.push_back({c, trial, gate});
  }
  if (calibrated.empty()) {
    std::cerr << "gap_referee: --condition must be roller, ground, roller_vs_road or all\n";
    return 64;
  }
  nlohmann::ordered_json j;
  j["schema"] = dry_run ? "brakefit.gap_referee_plan/1" : "brakefit.gap_referee/1";
  j["version"] = kVersion;
  j["seed"] = st.seed;
  j["stations"] = stations;
  if (export_hz > 0) j["export_hz"] = export_hz;
  j["tyre_file"] = tyre_file;
  if (realign) j["realign_late_channel"] = true;
  if (dry_run) {
    j["rows"] = nlohmann::ordered_json::array();
    for (const auto& r : rows)
      j["rows"].push_back({{"condition", gap::to_string(r.condition)},
                           {"trial_generator", sim::to_string(r.trial)},
                           {"gate_generator", sim::to_string(r.gate)}});
    std::cout << j.dump() << "\n";
    return 0;
  }
  std::map<std::pair<gap::Condition, sim::Generator>, sim::GateCalibration> gates;
  for (const auto& [c, gens] : calibrated)
    for (auto g : gens) gates[{c, g}] = bench::calibrate(c, st, g);
  for (const auto& r : rows)
    j["conditions"].push_back(
        bench::run_condition(r.condition, st, r.trial, gates[{r.condition, r.gate}], r.gate));
  std::cout << "\n" << j.dump() << "\n";
  if (!results.empty()) {
    std::string command;
    for (int i = 0; i < argc; ++i) {
      if (i) command += ' ';
      // As typed: an argument with a space (a results key) in quotes, so the command reruns.
      const std::string arg = argv[i];
      command += arg.find(' ') == std::string::npos ? arg : '"' + arg + '"';
    }
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
  } catch (const Usage& e) {
    std::cerr << "gap_referee: " << e.what() << "\n";
    return 64;
  } catch (const std::exception& e) {
    std::cerr << "gap_referee: " << e.what() << "\n";
    return 70;
  }
}
