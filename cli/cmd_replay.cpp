#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <iostream>

#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "cli/recording.hpp"
#include "core/event_json.hpp"
#include "core/pipeline/event_csv.hpp"
#include "core/plot/charts.hpp"

namespace brakefit::cli {

namespace {

void add_run_options(CLI::App* cmd, RunOptions& ro, std::string& force) {
  cmd->add_option("--bench", ro.bench_file,
                  "bench calibration TOML (default: <stem>.bench.toml beside the log)");
  cmd->add_flag("--lenient", ro.lenient, "count and skip malformed log lines instead of failing");
  cmd->add_option("--force", force,
                  "force source: pressure (brake_gain_n_per_bar x pressure_bar) or tester")
      ->check(CLI::IsMember({"pressure", "tester"}))
      ->capture_default_str();
}

}  // namespace

void add_replay_command(CLI::App& app) {
  struct Opts {
    std::vector<std::string> files;
    std::string model, report, force = "pressure", method = "all", bench_model;
    bool json = false;
    RunOptions run;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "replay", "Replay recorded tests (candump logs or event CSVs) through the pipeline");
  cmd->add_option("runs", o->files, "candump logs or event CSVs")->required();
  cmd->add_option("--model", o->model,
                  "trained model (default: $BRAKEFIT_MODEL or the shipped model)");
  cmd->add_option("--method", o->method, "som|mlp|lm|hybrid|all")
      ->check(CLI::IsMember({"som", "mlp", "lm", "hybrid", "all"}))
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "one brakefit.event/1 JSON document per event, one per line");
  cmd->add_option("--report", o->report, "directory for per-event SVG plots and events.jsonl");
  add_run_options(cmd, o->run, o->force);
  cmd->add_option("--bench-model", o->bench_model,
                  "the bench's measurement model (brakefit gap --bench-model): each event is also "
                  "fitted with its effects undone, on the tyre's basis");
  cmd->callback([o] {
    const Model model = load_model(resolve_model_path(o->model));
    if (!o->bench_model.empty()) {
      o->run.pipeline.bench_model = load_bench_model(o->bench_model);
      spdlog::info("bench model {}: {} bench, {}", o->bench_model,
                   o->run.pipeline.bench_model->condition,
                   held_effects(*o->run.pipeline.bench_model));
    }
    const auto* bench_model = o->run.pipeline.bench_model.get();
    o->run.pipeline.force =
        o->force == "tester" ? pipeline::ForceSource::Tester : pipeline::ForceSource::Pressure;
    if (o->method != "all") {
      Method m{};
      parse(o->method, m);
      o->run.pipeline.methods = {m};
    }
    std::vector<Run> runs;
    for (const auto& f : o->files) {
      spdlog::info("replaying {}", f);
      runs.push_back(process_run(f, o->run, &model));
    }
    if (!o->report.empty()) make_output_dir(o->report);
    std::string jsonl;
    std::vector<LeftOut> left_out;  // flagged events: in their JSON (flags) and on stderr
    for (const Run& run : runs) {
      if (o->json) leave_out_if_empty(left_out, run);  // (the text names it below)
      for (const auto& e : run.events) {
        if (!e.event.fittable()) leave_out(left_out, run, e.event, flagged_reason(e.event));
        const auto doc = event_json(e, run.path, &model);
        jsonl += doc.dump() + "\n";
        if (!o->report.empty() && !e.results.empty()) {
          const std::string svg =
              fmt::format("{}/{}-event-{}.svg", o->report,
                          std::filesystem::path(run.path).stem().string(), e.event.event_id);
          write_file(svg, plot::fit_chart_svg(
                              fmt::format("{} event {} ({}, {})", run.path, e.event.event_id,
                                          can::to_string(e.event.bench), e.event.end_reason),
                              e.curve, e.results, SlipUnit::Percent));
        }
        if (!o->json) print_event(run, e, bench_model);
      }
      if (!o->json && run.events.empty()) std::cout << run.path << ": no brake event found\n";
    }
    if (o->json) std::cout << jsonl;
    if (!o->report.empty()) {
      write_file(o->report + "/events.jsonl", jsonl);
      spdlog::info("report written to {}", o->report);
    }
  });
}

void add_export_command(CLI::App& app) {
  struct Opts {
    std::vector<std::string> files;
    std::string dir, force = "pressure";
    RunOptions run;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("export", "Write each brake event of a recording as an event CSV");
  cmd->add_option("runs", o->files, "candump logs")->required();
  cmd->add_option("--events", o->dir, "output directory")->required();
  add_run_options(cmd, o->run, o->force);
  cmd->callback([o] {
    o->run.pipeline.fit = false;
    make_output_dir(o->dir);
    for (const auto& f : o->files) {
      const Run run = process_run(f, o->run, nullptr);
      for (const auto& e : run.events) {
        const std::string out =
            fmt::format("{}/{}-event-{}.csv", o->dir, std::filesystem::path(f).stem().string(),
                        e.event.event_id);
        write_file(out, pipeline::format_event_csv(e.event, run.calibration));
        std::cout << fmt::format("{}: event {} ({} samples, {}) -> {}\n", f, e.event.event_id,
                                 e.event.samples.size(), e.event.end_reason, out);
      }
    }
  });
}

}  // namespace brakefit::cli
