#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <iostream>

#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "drivers/candump_file.hpp"
#include "sim/simulator.hpp"

namespace brakefit::cli {

void add_simulate_command(CLI::App& app) {
  struct Opts {
    std::string scenario, out, ramp;
    std::int64_t seed = -1;
    double tyre_pressure_bar = 0.0;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "simulate", "Simulate a roller or flat-ground brake test and record it as a candump log");
  // No CLI::ExistingFile: a missing scenario is a missing input (66), not a usage error.
  cmd->add_option("scenario", o->scenario, "scenario TOML (sim/scenarios/)")->required();
  cmd->add_option("--out", o->out,
                  "candump log to write; <stem>.bench.toml and <stem>.truth.json go beside it")
      ->required();
  cmd->add_option("--ramp", o->ramp, "override the pedal ramp: slow, medium, fast or bar/s");
  cmd->add_option("--seed", o->seed, "override the scenario seed");
  cmd->add_option("--tyre-pressure", o->tyre_pressure_bar,
                  "override the tyre inflation pressure [bar]")
      ->check(CLI::Range(0.5, 10.0));
  cmd->callback([o] {
    const std::string text = read_file(o->scenario);
    sim::Scenario sc;
    try {
      sc = sim::parse_scenario(text, o->scenario);
      if (!o->ramp.empty()) {
        sc.pedal_ramp = o->ramp;
        sc.ramp_bar_per_s = sim::ramp_rate_bar_per_s(o->ramp);
      }
    } catch (const InputError& e) {
      throw ExitError(kExitConfig, e.what());
    }
    if (o->seed >= 0) sc.seed = static_cast<std::uint64_t>(o->seed);
    if (o->tyre_pressure_bar > 0) sc.tyre_pressure_bar = o->tyre_pressure_bar;
    const sim::SimResult r = sim::simulate(sc);
    make_parent_dir(o->out);
    drivers::write_candump_file(o->out, r.frames);
    const std::string stem = recording_stem(o->out);
    write_file(stem + ".bench.toml", pipeline::format_calibration(r.calibration));
    write_file(stem + ".truth.json", sim::truth_json(sc, r, text));
    std::cout << fmt::format(
        "{}: {} bench, {} frames over {:.2f} s, ended by {} at {:.2f} s; tyre Pac96 equivalent B "
        "{:.3f} C {:.4f} "
        "D {:.1f} E {:.4f}; effects: {}\n",
        o->out, can::to_string(sc.bench), r.frames.size(), r.duration_s, r.end_reason, r.end_t_s,
        r.truth.B, r.truth.C, r.truth.D, r.truth.E,
        r.effects.empty() ? "none" : fmt::format("{}", fmt::join(r.effects, ", ")));
  });
}

}  // namespace brakefit::cli
