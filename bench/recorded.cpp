// Measurements on recorded tests: (1) identification on the shipped recordings against the
// simulator's ground truth, per method; (2) replay throughput (decode + speeds + slip + event
// detection, fitting excluded) side by side with can-utils log2asc on the same log.
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "cli/recording.hpp"
#include "core/can/candump.hpp"
#include "drivers/candump_file.hpp"

using namespace brakefit;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

MfParams truth_of(const std::string& log) {
  const auto j = nlohmann::json::parse(cli::read_file(cli::recording_stem(log) + ".truth.json"));
  const auto& p = j.at("pac96_equivalent");
  return {p.at("B").get<double>(),
          p.at("C").get<double>(),
          p.at("D").get<double>(),
          p.at("E").get<double>(),
          0,
          0};
}

void identification(const std::string& dir, const Model& model) {
  std::vector<std::string> logs;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".log") logs.push_back(e.path().string());
  std::sort(logs.begin(), logs.end());
  std::cout << "### Identification on the shipped recordings vs the simulator's ground truth\n\n"
               "Force from pressure (brake_gain_n_per_bar x pressure_bar, as in the paper); truth "
               "= the tyre's "
               "Pac96 equivalent on that surface at the static load. Realistic effects are on in "
               "every recording "
               "(see each .truth.json), so the errors below are the sim-to-real gap, not fitting "
               "error.\n\n"
               "| recording | method | B fit / true | C fit / true | D fit / true | E fit (true) | "
               "RMSE N | MAPE % | peak in data |\n"
               "|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& log : logs) {
    cli::RunOptions ro;
    const cli::Run run = cli::process_run(log, ro, &model);
    const MfParams t = truth_of(log);
    for (const auto& e : run.events)
      for (const auto& r : e.results)
        std::cout << fmt::format(
            "| {} | {} | {:.3f} | {:.3f} | {:.3f} | {:.3f} ({:.3f}) | {:.1f} | {:.2f} | {} |\n",
            std::filesystem::path(log).stem().string(), to_string(r.method), r.params.B / t.B,
            r.params.C / t.C, r.params.D / t.D, r.params.E, t.E, r.metrics.rmse_n,
            r.metrics.mape_pct, r.peak_reached ? "yes" : "no");
  }
}

void throughput(const std::string& scenario_log, int repeats) {
  // A long log: the same recording repeated back to back with shifted timestamps.
  const can::CandumpText one = drivers::read_candump_file(scenario_log);
  const std::int64_t span = one.frames.back().t_us - one.frames.front().t_us + 1'000'000;
  std::vector<can::LoggedFrame> frames;
  frames.reserve(one.frames.size() * static_cast<std::size_t>(repeats));
  for (int k = 0; k < repeats; ++k)
    for (auto f : one.frames) {
      f.t_us += k * span;
      frames.push_back(f);
    }
  const std::string big =
      (std::filesystem::temp_directory_path() / "brakefit-throughput.log").string();
  drivers::write_candump_file(big, frames);
  const std::string bench_toml = cli::recording_stem(scenario_log) + ".bench.toml";
  std::filesystem::copy_file(bench_toml, cli::recording_stem(big) + ".bench.toml",
                             std::filesystem::copy_options::overwrite_existing);
  spdlog::info("throughput log: {} frames ({} MB)", frames.size(),
               std::filesystem::file_size(big) / 1000000);
  double ours_best = 1e300, theirs_best = 1e300;
  std::size_t events = 0;
  for (int rep = 0; rep < 3; ++rep) {
    auto t0 = std::chrono::steady_clock::now();
    cli::RunOptions ro;
    ro.pipeline.fit = false;
    const cli::Run run =
        cli::process_run(big, ro, nullptr);  // read file + parse + decode + slip + events
    ours_best = std::min(ours_best, seconds_since(t0));
    events = run.events.size();
    t0 = std::chrono::steady_clock::now();
    const int rc = std::system(fmt::format("log2asc -I '{}' -O /dev/null can0", big).c_str());
    theirs_best = std::min(theirs_best, seconds_since(t0));
    if (rc != 0) throw std::runtime_error("log2asc failed (is can-utils installed?)");
    spdlog::info("round {}: brakefit {:.3f} s, log2asc {:.3f} s", rep + 1, ours_best, theirs_best);
  }
  const double n = static_cast<double>(frames.size());
  std::cout << fmt::format(
      "\n### Replay throughput (best of 3, same log)\n\n"
      "| reader | frames | seconds | frames/s |\n|---|---|---|---|\n"
      "| brakefit replay pipeline (read, parse, decode, speeds, slip, events; {} events; no "
      "fitting) | {} | {:.3f} | {:.3g} |\n"
      "| can-utils log2asc (read, parse, write ASC to /dev/null) | {} | {:.3f} | {:.3g} |\n\n"
      "ratio brakefit / log2asc = {:.2f}x (target >= 1x)\n",
      events, frames.size(), ours_best, n / ours_best, frames.size(), theirs_best, n / theirs_best,
      theirs_best / ours_best);
  std::filesystem::remove(big);
  std::filesystem::remove(cli::recording_stem(big) + ".bench.toml");
}

int run(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("recorded"));
  CLI::App app{"brakefit measurements on recorded tests"};
  std::string dir = "data/recorded", model_path;
  int repeats = 40;
  bool skip_throughput = false;
  app.add_option("--dir", dir, "recordings")->capture_default_str();
  app.add_option("--model", model_path, "model");
  app.add_option("--repeats", repeats, "copies of a recording in the throughput log")
      ->capture_default_str();
  app.add_flag("--no-throughput", skip_throughput, "identification table only");
  CLI11_PARSE(app, argc, argv);
  const Model model = cli::load_model(cli::resolve_model_path(model_path));
  identification(dir, model);
  if (!skip_throughput) throughput(dir + "/roller_2p2bar_slow.log", repeats);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "recorded: error: " << e.what() << "\n";
    return 1;
  }
}
