#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "brakefit/version.hpp"
#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "cli/recording.hpp"
#include "core/curve_csv.hpp"
#include "core/event_json.hpp"
#include "core/pipeline/event_csv.hpp"
#include "core/plot/charts.hpp"

namespace brakefit::cli {

namespace {

std::string plot_path_for(const std::string& plot, const std::string& file, std::size_t n_files) {
  if (n_files == 1) return plot;
  const std::filesystem::path p(plot);
  return (p.parent_path() / (p.stem().string() + "-" + std::filesystem::path(file).stem().string() +
                             p.extension().string()))
      .string();
}

}  // namespace

void add_fit_command(CLI::App& app) {
  struct Opts {
    std::string method = "all", model, plot, slip_unit = "ratio", bench_model;
    bool json = false, shifts = false;
    std::vector<std::string> files;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "fit",
      "Identify B, C, D, E of brake-slip curves (CSV: slip,force_n or slip_pct,force_n) or of "
      "exported events");
  cmd->add_option("--method", o->method, "som|mlp|lm|hybrid|all")
      ->check(CLI::IsMember({"som", "mlp", "lm", "hybrid", "all"}))
      ->capture_default_str();
  cmd->add_option("--model", o->model,
                  "trained model (default: $BRAKEFIT_MODEL or the shipped model)");
  cmd->add_flag("--json", o->json,
                "print one JSON document (brakefit.fit/1) per file, one per line");
  cmd->add_option("--plot", o->plot,
                  "write measured vs fitted curves as SVG (several files: OUT-<name>.svg)");
  cmd->add_option("--slip-unit", o->slip_unit,
                  "slip unit for the table and plot axes (JSON keeps ratios)")
      ->check(CLI::IsMember({"ratio", "percent"}))
      ->capture_default_str();
  cmd->add_flag("--shifts", o->shifts, "least-squares methods also fit SHx and SVx");
  cmd->add_option("--bench-model", o->bench_model,
                  "the bench's measurement model (brakefit gap --bench-model): each event CSV is "
                  "also fitted with its effects undone, on the tyre's basis");
  cmd->add_option("files", o->files,
                  "curve CSV files, or event CSVs (brakefit export: fitted as replay fits them, "
                  "brakefit.event/1 with --json)")
      ->required();
  cmd->callback([o] {
    std::vector<Method> methods;
    if (o->method == "all") {
      methods = {Method::Som, Method::Mlp, Method::Lm, Method::Hybrid};
    } else {
      Method m{};
      parse(o->method, m);
      methods = {m};
    }
    // Event CSVs are fitted as replay fits them (and need the model for their calibration's
    // conditioning); the rest are curves.
    std::vector<std::string> event_files, curve_files;
    for (const auto& f : o->files)
      (pipeline::looks_like_event_csv(read_file(f)) ? event_files : curve_files).push_back(f);
    std::shared_ptr<const gap::BenchModel> bench_model;
    if (!o->bench_model.empty()) {
      if (event_files.empty())
        throw ExitError(
            kExitUsage,
            "--bench-model undoes a bench's effects on an event's samples: give event CSVs "
            "(brakefit export), not curve CSVs");
      bench_model = load_bench_model(o->bench_model);
    }
    const bool needs_model = o->method != "lm" || !o->model.empty() || !event_files.empty();
    std::optional<Model> model;
    if (needs_model) model = load_model(resolve_model_path(o->model));
    // Parse every file before printing anything: a bad file means no partial output.
    std::vector<Run> runs;
    if (!event_files.empty()) {
      RunOptions ro;
      ro.pipeline.methods = methods;
      ro.pipeline.bench_model = bench_model;
      for (const auto& f : event_files) runs.push_back(process_run(f, ro, &*model));
    }
    if (!o->plot.empty() && !event_files.empty())
      spdlog::warn("--plot draws curve CSVs; `brakefit replay --report DIR` draws events");
    if (bench_model && !curve_files.empty())
      spdlog::warn(
          "--bench-model is not applied to curve CSVs ({}): a curve has no samples in "
          "time to undo a bench's effects on",
          fmt::join(curve_files, ", "));
    std::vector<ParsedCurve> curves;
    curves.reserve(curve_files.size());
    for (const auto& f : curve_files) curves.push_back(parse_curve_csv(read_file(f), f));
    for (const Run& run : runs)
      for (const auto& e : run.events) {
        if (o->json)
          std::cout << event_json(e, run.path, &*model).dump() << "\n";
        else
          print_event(run, e, bench_model.get());
      }
    fit::MfFitOptions fit_opts = fit_options_for(model ? &*model : nullptr);
    fit_opts.fit_shifts = o->shifts;
    const SlipUnit unit = o->slip_unit == "percent" ? SlipUnit::Percent : SlipUnit::Ratio;
    std::vector<std::vector<MethodResult>> all;
    all.reserve(curves.size());
    for (std::size_t i = 0; i < curves.size(); ++i) {
      spdlog::debug("fitting {} ({} points)", curve_files[i], curves[i].curve.size());
      std::vector<MethodResult> rs;
      rs.reserve(methods.size());
      for (Method m : methods) {
        rs.push_back(run_method(m, model ? &*model : nullptr, curves[i].curve, fit_opts));
        // A curve file carries no wheel load: its shape alone is judged.
        flag_implausible(rs.back(), std::nan(""));
      }
      all.push_back(std::move(rs));
    }
    for (std::size_t i = 0; i < curves.size(); ++i) {
      const auto& c = curves[i].curve;
      if (!o->plot.empty()) {
        const std::string path = plot_path_for(o->plot, curve_files[i], curves.size());
        write_file(path, plot::fit_chart_svg(fmt::format("{}: measured vs fitted", curve_files[i]),
                                             c, all[i], unit));
        spdlog::info("plot written to {}", path);
      }
      if (o->json) {
        nlohmann::ordered_json doc;
        doc["schema"] = "brakefit.fit/1";
        doc["version"] = kVersion;
        doc["model_hash"] =
            model ? nlohmann::ordered_json(model->hash) : nlohmann::ordered_json(nullptr);
        doc["file"] = curve_files[i];
        doc["slip_unit"] = to_string(curves[i].input_unit);
        doc["points"] = c.size();
        doc["mape_rule"] = kMapeRule;
        doc["results"] = nlohmann::ordered_json::array();
        for (const auto& r : all[i]) doc["results"].push_back(result_json(r));
        std::cout << doc.dump() << "\n";
        continue;
      }
      const bool pct = unit == SlipUnit::Percent;
      std::cout << fmt::format("{}: {} points (input slip in {}), model {}\n", curve_files[i],
                               c.size(), to_string(curves[i].input_unit),
                               model ? model->hash.substr(0, 19) : "none");
      std::cout << fmt::format("  {:<7} {:>10} {:>7} {:>9} {:>8} {:>8} {:>8} {:>9} {:>9}  {}\n",
                               "method", pct ? "B [1/%]" : "B [1/-]", "C", "D [N]", "E", "MAPE %",
                               "RMSE N", "peak N", pct ? "peak %" : "peak [-]", "notes");
      for (std::size_t m = 0; m < all[i].size(); ++m) {
        const auto& r = all[i][m];
        const MfPeak pk = mf_peak(r.params, 1.0);
        const std::string notes = result_notes(all[i], m);
        std::cout << fmt::format(
            "  {:<7} {:>10.4f} {:>7.4f} {:>9.1f} {:>8.4f} {:>8.3f} {:>8.2f} {:>9.1f} {:>9.4f}  "
            "{}\n",
            to_string(r.method), pct ? r.params.B / 100.0 : r.params.B, r.params.C, r.params.D,
            r.params.E, r.metrics.mape_pct, r.metrics.rmse_n, pk.force_n,
            pct ? pk.slip_ratio * 100.0 : pk.slip_ratio, notes.empty() ? "-" : notes);
        if (r.stderr_) {
          const auto& s = *r.stderr_;
          std::cout << fmt::format(
              "  {:<7} {:>10.4f} {:>7.4f} {:>9.1f} {:>8.4f}   (standard errors)\n", "  +/-",
              pct ? s[0] / 100.0 : s[0], s[1], s[2], s[3]);
        }
      }
      std::cout << fmt::format("  MAPE: {}; {} excluded here\n", kMapeRule,
                               all[i].empty() ? 0 : all[i][0].metrics.mape_points_excluded);
    }
  });
}

}  // namespace brakefit::cli
