// brakefit tyre: MF 6.1 pure longitudinal coefficients fitted jointly over brake events at their
// own loads, pressures and speeds, written as a .tir file; with --scale-from/--to, one rig relative
// to the other as MF scaling factors in that file.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "brakefit/version.hpp"
#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "cli/recording.hpp"
#include "cli/tyre_report.hpp"
#include "core/curve_csv.hpp"
#include "core/event_json.hpp"
#include "core/pipeline/event_csv.hpp"
#include "core/tyre/charts.hpp"
#include "core/tyre/curve_conditions.hpp"
#include "core/tyre/tir_writer.hpp"

namespace brakefit::cli {

namespace {

struct Loaded {
  std::vector<tyre::TyreCurve> curves;
  std::vector<LeftOut> left_out;
  double wheel_radius_m = NAN;
  std::vector<std::string> notes;
};

bool is_run(const std::string& path, const std::string& text) {
  return std::filesystem::path(path).extension() == ".log" || pipeline::looks_like_event_csv(text);
}

/// Every finished event of a recorded run (on the tyre's basis with a bench model), or a curve
/// CSV with its conditions in its header.
void load(const std::string& path, const RunOptions& ro, const Model& model, double pressure_bar,
          double speed_kmh, Loaded& out) {
  const std::string text = read_file(path);
  if (is_run(path, text)) {
    Run run = process_run(path, ro, &model);
    leave_out_if_empty(out.left_out, run);
    for (auto& e : run.events) {
      if (!e.event.fittable()) {
        leave_out(out.left_out, run, e.event, flagged_reason(e.event));
        continue;
      }
      const bool tyre_basis = ro.pipeline.bench_model != nullptr;
      if (tyre_basis && e.tyre_results.empty()) {
        leave_out(out.left_out, run, e.event,
                  fmt::format("no tyre points: {}", fmt::join(e.tyre_notes, "; ")));
        continue;
      }
      tyre::TyreCurve tc = tyre_curve(fmt::format("{} event {}", path, e.event.event_id),
                                      tyre_basis ? e.tyre_curve : e.curve, run.calibration,
                                      tyre_basis ? e.tyre_results : e.results);
      if (tc.curve.size() < kMinCurvePoints) {
        leave_out(out.left_out, run, e.event,
                  fmt::format("{} points, a curve needs {}", tc.curve.size(), kMinCurvePoints));
        continue;
      }
      out.wheel_radius_m = run.calibration.wheel_radius_m;
      out.curves.push_back(std::move(tc));
    }
    return;
  }
  const ParsedCurve pc = parse_curve_csv(text, path);
  const tyre::CurveConditions cc = tyre::parse_curve_conditions(text, path);
  if (std::isnan(cc.wheel_load_n))
    throw InputError(
        fmt::format("{}: no '# wheel_load_n=' line: the tyre fit needs each curve's "
                    "wheel load",
                    path));
  tyre::TyreCurve tc;
  tc.source = path;
  tc.curve = pc.curve;
  double p_bar = cc.tyre_pressure_bar, v_kmh = cc.speed_kmh;
  if (std::isnan(p_bar)) {
    p_bar = pressure_bar;
    out.notes.push_back(fmt::format("{}: no tyre_pressure_bar, taken as {:g} bar", path, p_bar));
  }
  if (std::isnan(v_kmh)) {
    v_kmh = speed_kmh;
    out.notes.push_back(fmt::format("{}: no speed_kmh, taken as {:g} km/h", path, v_kmh));
  }
  tc.op = {cc.wheel_load_n, p_bar * 1e5, v_kmh / 3.6};
  if (!std::isnan(cc.wheel_radius_m)) out.wheel_radius_m = cc.wheel_radius_m;
  out.curves.push_back(std::move(tc));
}

void print_table(const tyre::Mf61FitResult& fit) {
  fmt::print("MF 6.1 from {} curves ({} loads, {} pressures, {} speeds): RMS {:.2f} % of peak\n",
             fit.curves.size(), fit.loads, fit.pressures, fit.speeds, fit.rms_pct_peak);
  for (std::size_t i = 0; i < tyre::kCoefCount; ++i) {
    const std::string reason = fit.held_reason(i);
    if (reason.empty())
      fmt::print("  {:<5} {:>12.6g}  +- {:.3g}\n", tyre::coef_name(i), fit.tyre.coef[i],
                 fit.stderr_[i]);
    else
      fmt::print("  {:<5} {:>12.6g}  held: {}\n", tyre::coef_name(i), fit.tyre.coef[i], reason);
  }
}

}  // namespace

void add_tyre_command(CLI::App& app) {
  struct Opts {
    std::string out, svg_dir, model, bench_file, bench_model;
    bool json = false, lenient = false;
    double pressure_bar = 2.2, speed_kmh = 5.0, fnomin_n = NAN, nompres_bar = NAN;
    std::vector<std::string> runs, scale_from, to;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "tyre",
      "Fit MF 6.1 pure longitudinal coefficients over brake events at several loads and "
      "pressures and write them as a .tir file");
  cmd->add_option("--out", o->out, "the .tir file to write")->required();
  cmd->add_flag("--json", o->json, "print the fit as JSON (brakefit.tyre/1)");
  cmd->add_option("--svg", o->svg_dir, "write curves.svg and loads.svg (and rig.svg) here");
  cmd->add_option("--model", o->model, "trained model (default: the shipped model)");
  cmd->add_option("--bench", o->bench_file, "bench calibration for logs (else <stem>.bench.toml)");
  cmd->add_option("--bench-model", o->bench_model,
                  "a bench measurement model: fit the tyre's points, the bench's effects undone");
  cmd->add_flag("--lenient", o->lenient, "skip (and count) malformed log lines");
  cmd->add_option("--pressure-bar", o->pressure_bar,
                  "tyre pressure of curve CSVs without a tyre_pressure_bar line")
      ->capture_default_str();
  cmd->add_option("--speed-kmh", o->speed_kmh, "speed of curve CSVs without a speed_kmh line")
      ->capture_default_str();
  cmd->add_option("--fnomin-n", o->fnomin_n, "FNOMIN, N (default: the median load)");
  cmd->add_option("--nompres-bar", o->nompres_bar, "NOMPRES, bar (default: the median pressure)");
  cmd->add_option("--scale-from", o->scale_from,
                  "a rig's runs (the roller's): written as scaling factors relative to --to");
  cmd->add_option("--to", o->to, "the reference runs (the road's) the tyre file is fitted to");
  cmd->add_option("runs", o->runs, "recorded logs, event CSVs or curve CSVs with # wheel_load_n=");
  cmd->callback([o] {
    if (o->scale_from.empty() != o->to.empty())
      throw ExitError(kExitUsage, "--scale-from and --to go together");
    if (!o->scale_from.empty() && !o->runs.empty())
      throw ExitError(kExitUsage, "with --scale-from/--to, the runs are given there, not after");
    if (o->runs.empty() && o->to.empty()) throw ExitError(kExitUsage, "no runs given");
    const Model model = load_model(resolve_model_path(o->model));
    RunOptions ro;
    ro.bench_file = o->bench_file;
    ro.lenient = o->lenient;
    ro.pipeline.methods = {Method::Lm};
    if (!o->bench_model.empty()) ro.pipeline.bench_model = load_bench_model(o->bench_model);
    const auto& tyre_runs = o->to.empty() ? o->runs : o->to;
    Loaded tyre_in, rig_in;
    for (const auto& f : tyre_runs) load(f, ro, model, o->pressure_bar, o->speed_kmh, tyre_in);
    for (const auto& f : o->scale_from) load(f, ro, model, o->pressure_bar, o->speed_kmh, rig_in);
    for (const auto& n : tyre_in.notes) spdlog::warn("{}", n);
    for (const auto& n : rig_in.notes) spdlog::warn("{}", n);
    if (tyre_in.curves.empty())
      throw InputError(fmt::format("no fitted brake event or curve in the runs ({} left out)",
                                   tyre_in.left_out.size()));
    tyre::Mf61FitOptions fo;
    fo.fnomin_n = o->fnomin_n;
    fo.nompres_pa = o->nompres_bar * 1e5;
    const auto t0 = std::chrono::steady_clock::now();
    const tyre::Mf61FitResult fit = tyre::fit_mf61(tyre_in.curves, fo);
    std::optional<tyre::ScalingFit> scaling;
    if (!rig_in.curves.empty())
      scaling = tyre::fit_scalings(fit.tyre, rig_in.curves, fo);
    else if (!o->scale_from.empty())
      throw InputError(fmt::format("--scale-from: no fitted brake event or curve ({} left out)",
                                   rig_in.left_out.size()));
    const double fit_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    spdlog::info("MF 6.1 fit of {} curves: {} solves, {:.2f} s", tyre_in.curves.size(), fit.solves,
                 fit_s);

    tyre::TirProvenance prov;
    prov.brakefit_version = kVersion;
    prov.model_hash = model.hash;
    prov.runs = tyre_runs;
    if (scaling)
      for (const auto& r : o->scale_from) prov.runs.push_back("scaling from: " + r);
    prov.rolling_radius_m = tyre_in.wheel_radius_m;
    make_parent_dir(o->out);
    write_file(o->out, tyre::format_tir(fit, prov, scaling));

    if (!o->svg_dir.empty()) {
      make_output_dir(o->svg_dir);
      write_file(o->svg_dir + "/curves.svg",
                 tyre::curves_svg("Brake curves and the MF 6.1 file", fit.tyre, tyre_in.curves));
      write_file(o->svg_dir + "/loads.svg", tyre::loads_svg(fit.tyre, tyre_in.curves));
      if (scaling)
        write_file(o->svg_dir + "/rig.svg",
                   tyre::curves_svg("The rig's curves and the file with its scaling factors",
                                    fit.tyre, rig_in.curves, &*scaling));
    }
    std::vector<LeftOut> left_out = tyre_in.left_out;
    left_out.insert(left_out.end(), rig_in.left_out.begin(), rig_in.left_out.end());
    if (o->json) {
      nlohmann::ordered_json j;
      j["schema"] = "brakefit.tyre/1";
      j["version"] = kVersion;
      j["model_hash"] = model.hash;
      j["out"] = o->out;
      j["inputs"] = tyre_runs;
      j["basis"] = o->bench_model.empty() ? "instrument" : "tyre";
      j["fit"] = fit_json(fit);
      j["fit_seconds"] = fit_s;
      if (scaling) j["scaling"] = factors_json(*scaling);
      j["notes"] = tyre_in.notes;
      j["left_out"] = left_out_json(left_out);
      std::cout << j.dump() << "\n";
    } else {
      print_table(fit);
      if (scaling) {
        fmt::print(
            "The rig relative to the file ({} curves): RMS {:.2f} % of peak ({:.2f} % "
            "unscaled)\n",
            scaling->curves.size(), scaling->rms_pct_peak, scaling->unscaled_rms_pct_peak);
        fmt::print("{}", factors_text(*scaling));
      }
      fmt::print("wrote {}\n", o->out);
    }
  });
}

}  // namespace brakefit::cli
