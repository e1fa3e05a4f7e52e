#include "cli/recording.hpp"

#include <spdlog/spdlog.h>

#include <fmt/ranges.h>

#include <filesystem>
#include <iostream>

#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "core/can/candump.hpp"
#include "core/event_json.hpp"
#include "core/pipeline/event_csv.hpp"

namespace brakefit::cli {

namespace {

/// The first line that is not blank or a comment is a curve CSV's header.
bool looks_like_curve_csv(std::string_view text) {
  std::size_t pos = 0;
  while (pos < text.size()) {
    auto nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    std::string_view line = text.substr(pos, nl - pos);
    pos = nl + 1;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.remove_suffix(1);
    if (line.empty() || line.front() == '#') continue;
    return line.rfind("slip,", 0) == 0 || line.rfind("slip_pct,", 0) == 0;
  }
  return false;
}

}  // namespace

Run process_run(const std::string& path, const RunOptions& o, const Model* model) {
  Run run;
  run.path = path;
  const std::string text = read_file(path);
  if (pipeline::looks_like_event_csv(text)) {
    const pipeline::EventCsv ev = pipeline::parse_event_csv(text, path);
    run.calibration = ev.calibration;
    pipeline::PipelineOptions po = o.pipeline;
    po.events = pipeline::event_csv_settings(ev, po.events);
    if (po.force == pipeline::ForceSource::Tester && !ev.has_force)
      throw InputError(path + ": --force tester needs a force_n column");
    pipeline::Pipeline p(run.calibration, po, model);
    if (ev.repeated_stamps)
      spdlog::warn(
          "{}: {} rows repeated the previous row's time stamp (a coarse clock); they were "
          "spread evenly up to the next stamp",
          path, ev.repeated_stamps);
    for (const auto& s : ev.samples) p.feed(s);
    p.finish_file();  // an event file is one event: its last row ends it
    run.events = std::move(p.events());
    return run;
  }
  if (looks_like_curve_csv(text))
    throw InputError(path +
                     ": a curve CSV (slip, force_n), not a recording or an event file: fit it "
                     "with `brakefit fit " +
                     path + "`");
  std::string bench = o.bench_file;
  if (bench.empty()) {
    bench = recording_stem(path) + ".bench.toml";
    if (!std::filesystem::exists(bench))
      throw InputError(path + ": no bench calibration: give --bench FILE or put " + bench +
                       " beside the log");
  }
  try {
    run.calibration = pipeline::parse_calibration(read_file(bench), bench);
  } catch (const InputError& e) {
    throw ExitError(kExitConfig, e.what());
  }
  const can::CandumpText log = can::parse_candump_text(text, path, o.lenient);
  run.malformed_lines = log.malformed;
  run.ignored_lines = log.ignored;
  if (log.malformed)
    spdlog::warn("{}: {} malformed lines skipped (--lenient)", path, log.malformed);
  pipeline::Pipeline p(run.calibration, o.pipeline, model);
  for (const auto& f : log.frames) p.feed(f);
  p.finish();
  run.stats = p.sample_stats();
  if (run.stats.unknown_ids)
    spdlog::info("{}: {} frames with unknown ids ignored", path, run.stats.unknown_ids);
  // A log cut short: its last line without a newline, frames shorter than their message, or no
  // frames at all. Warned and counted (run.truncated), never silent.
  if (!text.empty() && text.back() != '\n') {
    ++run.truncated;
    spdlog::warn("{}: the last line has no newline: the log was cut (its last frame may be short)",
                 path);
  }
  if (run.stats.short_frames) {
    run.truncated += run.stats.short_frames;
    spdlog::warn("{}: {} frame(s) shorter than their message ignored (a log cut mid-frame)", path,
                 run.stats.short_frames);
  }
  if (log.frames.empty()) spdlog::warn("{}: no CAN frames in the log", path);
  run.events = std::move(p.events());
  return run;
}

void leave_out(std::vector<LeftOut>& out, const Run& run, const pipeline::Event& e,
               const std::string& reason) {
  spdlog::warn("{}: event {} left out: {}", run.path, e.event_id, reason);
  out.push_back({run.path, e.event_id, reason});
}

void leave_out_if_empty(std::vector<LeftOut>& out, const Run& run) {
  if (!run.events.empty()) return;
  spdlog::warn("{}: left out: no brake event found in it", run.path);
  out.push_back({run.path, 0, "no brake event found in the file"});
}

std::string flagged_reason(const pipeline::Event& e) {
  return fmt::format("flagged {} (ended by {}{})", fmt::join(e.flags, ", "), e.end_reason,
                     e.note.empty() ? "" : ": " + e.note);
}

nlohmann::ordered_json left_out_json(const std::vector<LeftOut>& left_out) {
  auto j = nlohmann::ordered_json::array();
  for (const auto& l : left_out)
    j.push_back({{"file", l.file}, {"event_id", l.event_id}, {"reason", l.reason}});
  return j;
}

std::shared_ptr<const gap::BenchModel> load_bench_model(const std::string& path) {
  const std::string text = read_file(path);
  try {
    return std::make_shared<const gap::BenchModel>(gap::parse_bench_model(text, path));
  } catch (const InputError& e) {
    throw ExitError(kExitDataError, e.what());
  }
}

std::string held_effects(const gap::BenchModel& bm) {
  std::vector<std::string> held;
  for (const auto& e : bm.effects)
    held.push_back(fmt::format("{} {} {:.4g}", gap::to_string(e.effect),
                               gap::effect_param(e.effect).name, e.value));
  return held.empty() ? std::string("no instrument effect")
                      : fmt::format("{}", fmt::join(held, ", "));
}

namespace {

/// One line per method: B, C, D, E, MAPE, RMSE and what must be said beside them.
void print_results(const std::vector<MethodResult>& results) {
  for (std::size_t m = 0; m < results.size(); ++m) {
    const auto& r = results[m];
    const std::string notes = result_notes(results, m);
    std::cout << fmt::format(
        "  {:<7} B {:>8.3f} C {:>6.4f} D {:>8.1f} E {:>8.4f}  MAPE {:>6.2f} %  RMSE {:>7.1f} N{}\n",
        to_string(r.method), r.params.B, r.params.C, r.params.D, r.params.E, r.metrics.mape_pct,
        r.metrics.rmse_n, notes.empty() ? "" : "  (" + notes + ")");
  }
}

}  // namespace

void print_event(const Run& run, const pipeline::EventResult& e,
                 const gap::BenchModel* bench_model) {
  std::cout << fmt::format(
      "{} event {}: {} bench, {:.2f} s, {} points to {:.1f} % slip, ended by {}{}\n", run.path,
      e.event.event_id, can::to_string(e.event.bench),
      static_cast<double>(e.event.t_end_ns - e.event.t_start_ns) * 1e-9, e.curve.size(),
      100 * e.curve.max_slip_ratio(), e.event.end_reason,
      e.event.flags.empty() ? "" : fmt::format(" [flags: {}]", fmt::join(e.event.flags, ", ")));
  print_results(e.results);
  if (bench_model && (!e.tyre_results.empty() || !e.tyre_notes.empty()))
    std::cout << fmt::format(
        "  the tyre's curve (the bench model's {} undone){}\n", held_effects(*bench_model),
        e.tyre_notes.empty() ? std::string() : fmt::format(": {}", fmt::join(e.tyre_notes, "; ")));
  print_results(e.tyre_results);
}

}  // namespace brakefit::cli
