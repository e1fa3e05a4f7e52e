// brakefit compare A B: the paper's Table VI (parameters side by side, with uncertainties) and
// Fig. 7 (the two fitted curves overlaid), plus each side's peak brake force and slip at the peak.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>

#include "brakefit/version.hpp"
#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "cli/recording.hpp"
#include "cli/tyre_report.hpp"
#include "core/event_json.hpp"
#include "core/pipeline/tyre_basis.hpp"
#include "core/plot/svg.hpp"

namespace brakefit::cli {

namespace {

struct Side {
  std::string label;
  std::vector<std::string> files;
  std::vector<MethodResult> fits;  ///< one per fitted event
  std::vector<Curve> curves;
  std::vector<tyre::TyreCurve> tyre_curves;  ///< the same curves where they were measured
  MfParams mean;                             ///< fit to the pooled points of all events
  std::array<double, 4> uncertainty{};       ///< standard errors of that fit
  std::array<double, 4> spread{};  ///< standard deviation of the per-event fits (NaN for one event)
  double rmse_n = 0.0;
  double peak_force_n = 0.0, peak_slip_ratio = 0.0;
  std::vector<LeftOut> left_out;                   ///< events not used, with the reason
  double wheel_load_n = NAN;                       ///< the first run's calibration
  std::vector<std::string> at_bound, implausible;  ///< of the pooled fit
  /// "tyre": the events' tyre points and fits (a bench measurement model's effects undone);
  /// "instrument": the raw force.
  std::string basis = "instrument";
  std::string bench_model;  ///< the model file applied (empty: none)
};

std::vector<std::string> expand(const std::string& p) {
  if (!std::filesystem::is_directory(p)) return {p};
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(p)) {
    const auto ext = e.path().extension().string();
    if (ext == ".log" || ext == ".csv") out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// One side from its runs (files or directories of them); label names it in tables and plots.
/// The bench models given, by the bench they describe ("roller", "ground").
using BenchModels =
    std::map<std::string, std::pair<std::string, std::shared_ptr<const gap::BenchModel>>>;

Side load_side(const std::vector<std::string>& paths, const std::string& label,
               const RunOptions& ro, const Model& model, Method method, const BenchModels& bms) {
  Side s;
  s.label = label;
  for (const auto& p : paths) {
    const auto files = expand(p);
    if (files.empty()) throw InputError(p + ": no .log or .csv runs in this directory");
    s.files.insert(s.files.end(), files.begin(), files.end());
  }
  for (const auto& f : s.files) {
    Run run = process_run(f, ro, &model);
    if (std::isnan(s.wheel_load_n)) s.wheel_load_n = run.calibration.wheel_load_n;
    leave_out_if_empty(s.left_out, run);
    for (auto& e : run.events) {
      if (!e.event.fittable()) leave_out(s.left_out, run, e.event, flagged_reason(e.event));
      // A side is fitted on the tyre's basis when a model of its bench was given: every event
      // then counts with its tyre points, or is left out with the reason it has none.
      const auto bm = bms.find(can::to_string(e.event.bench));
      if (bm != bms.end() && e.event.fittable()) {
        pipeline::add_tyre_results(e, run.calibration, *bm->second.second, &model,
                                   ro.pipeline.force);
        s.basis = "tyre";
        s.bench_model = bm->second.first;
        if (e.tyre_results.empty()) {
          leave_out(s.left_out, run, e.event,
                    fmt::format("no tyre points: {}", fmt::join(e.tyre_notes, "; ")));
          continue;
        }
      }
      const bool tyre = !e.tyre_results.empty();
      for (auto& r : tyre ? e.tyre_results : e.results)
        if (r.method == method) {
          s.fits.push_back(r);
          s.curves.push_back(tyre ? e.tyre_curve : e.curve);
          s.tyre_curves.push_back(tyre_curve(fmt::format("{} event {}", f, e.event.event_id),
                                             s.curves.back(), run.calibration,
                                             tyre ? e.tyre_results : e.results));
        }
    }
  }
  if (s.fits.empty())
    throw InputError(fmt::format("{}: no fitted brake event ({} left out, see the warnings)", label,
                                 s.left_out.size()));
  // One fit to the pooled points: averaging nonlinear parameters of poorly identified fits would
  // give a curve that goes through none of the data.
  Curve pooled;
  for (const auto& c : s.curves) {
    pooled.slip_ratio.insert(pooled.slip_ratio.end(), c.slip_ratio.begin(), c.slip_ratio.end());
    pooled.force_n.insert(pooled.force_n.end(), c.force_n.begin(), c.force_n.end());
  }
  const MethodResult all = run_method(method, &model, pooled, fit_options_for(&model));
  s.mean = all.params;
  s.rmse_n = all.metrics.rmse_n;
  s.at_bound = all.at_bound;
  s.implausible = implausible_curve(all.params, s.wheel_load_n);
  for (std::size_t k = 0; k < 4; ++k) s.uncertainty[k] = all.stderr_ ? (*all.stderr_)[k] : NAN;
  const double n = static_cast<double>(s.fits.size());
  std::array<double, 4> sum{}, sq{};
  for (const auto& r : s.fits) {
    const double v[4] = {r.params.B, r.params.C, r.params.D, r.params.E};
    for (std::size_t k = 0; k < 4; ++k) sum[k] += v[k], sq[k] += v[k] * v[k];
  }
  for (std::size_t k = 0; k < 4; ++k)
    s.spread[k] =
        s.fits.size() > 1 ? std::sqrt(std::max(0.0, (sq[k] - sum[k] * sum[k] / n) / (n - 1))) : NAN;
  const MfPeak pk = mf_peak(s.mean, 1.0);
  s.peak_force_n = pk.force_n;
  s.peak_slip_ratio = pk.slip_ratio;
  return s;
}

nlohmann::ordered_json side_json(const Side& s) {
  nlohmann::ordered_json j;
  j["label"] = s.label;
  j["files"] = s.files;
  j["basis"] = s.basis;
  j["bench_model"] = s.bench_model.empty() ? nlohmann::ordered_json(nullptr)
                                           : nlohmann::ordered_json(s.bench_model);
  j["events"] = s.fits.size();
  j["left_out"] = left_out_json(s.left_out);
  j["B"] = num(s.mean.B);
  j["C"] = num(s.mean.C);
  j["D"] = num(s.mean.D);
  j["E"] = num(s.mean.E);
  j["uncertainty"] = {{"B", num(s.uncertainty[0])},
                      {"C", num(s.uncertainty[1])},
                      {"D", num(s.uncertainty[2])},
                      {"E", num(s.uncertainty[3])}};
  j["uncertainty_kind"] = "standard error of the fit to the pooled points";
  j["spread_over_events"] = {{"B", num(s.spread[0])},
                             {"C", num(s.spread[1])},
                             {"D", num(s.spread[2])},
                             {"E", num(s.spread[3])}};
  j["at_bound"] = s.at_bound;
  j["implausible"] = s.implausible;
  j["rmse_n"] = num(s.rmse_n);
  j["peak_force_n"] = num(s.peak_force_n);
  j["peak_slip_ratio"] = num(s.peak_slip_ratio);
  return j;
}

}  // namespace

void add_compare_command(CLI::App& app) {
  struct Opts {
    std::string a, b, model, svg, method = "hybrid", force = "pressure";
    std::vector<std::string> roller, road, bench_models;
    bool json = false;
    RunOptions run;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "compare", "Compare two recordings or event sets (e.g. roller vs flat ground)");
  cmd->add_option("a", o->a,
                  "first recording, event CSV or directory of them (e.g. the roller tests)");
  cmd->add_option("b", o->b,
                  "second recording, event CSV or directory (e.g. the flat-ground tests)");
  cmd->add_option("--roller", o->roller,
                  "instead of A B: the roller runs (any number of files or directories)");
  cmd->add_option("--road", o->road, "with --roller: the flat-ground runs");
  cmd->add_option("--method", o->method, "identification method")
      ->check(CLI::IsMember({"som", "mlp", "lm", "hybrid"}))
      ->capture_default_str();
  cmd->add_option("--model", o->model,
                  "trained model (default: $BRAKEFIT_MODEL or the shipped model)");
  cmd->add_option("--bench-model", o->bench_models,
                  "a bench's measurement model (brakefit gap --bench-model; one per bench kind): "
                  "the events of that bench are compared on the tyre's basis");
  cmd->add_flag("--json", o->json, "print a brakefit.compare/1 JSON document");
  cmd->add_option("--svg", o->svg, "write the two fitted curves overlaid (paper Fig. 7)");
  cmd->add_option("--force", o->force, "force source: pressure or tester")
      ->check(CLI::IsMember({"pressure", "tester"}))
      ->capture_default_str();
  cmd->callback([o] {
    const Model model = load_model(resolve_model_path(o->model));
    Method method{};
    parse(o->method, method);
    o->run.pipeline.methods = {method};
    o->run.pipeline.force =
        o->force == "tester" ? pipeline::ForceSource::Tester : pipeline::ForceSource::Pressure;
    const bool positional = !o->a.empty() || !o->b.empty();
    const bool named = !o->roller.empty() || !o->road.empty();
    if (positional == named || (positional && (o->a.empty() || o->b.empty())) ||
        (named && (o->roller.empty() || o->road.empty())))
      throw ExitError(kExitUsage,
                      "compare: give A B (two runs or directories), or --roller RUNS... --road "
                      "RUNS...");
    BenchModels bms;
    for (const auto& f : o->bench_models) {
      auto bm = load_bench_model(f);
      const std::string kind = bm->condition;
      if (!bms.emplace(kind, std::make_pair(f, std::move(bm))).second)
        throw ExitError(kExitUsage,
                        fmt::format("compare: two bench models of a {} bench ({} and {})", kind,
                                    bms.at(kind).first, f));
      spdlog::info("bench model {}: {} bench, {}", f, kind, held_effects(*bms.at(kind).second));
    }
    auto name = [](const std::string& p) { return std::filesystem::path(p).filename().string(); };
    auto runs_label = [](const char* what, const std::vector<std::string>& v) {
      return v.size() == 1 ? std::filesystem::path(v[0]).filename().string()
                           : fmt::format("{} ({})", what, count(v.size(), "run"));
    };
    const Side a = positional ? load_side({o->a}, name(o->a), o->run, model, method, bms)
                              : load_side(o->roller, runs_label("roller", o->roller), o->run, model,
                                          method, bms);
    const Side b =
        positional ? load_side({o->b}, name(o->b), o->run, model, method, bms)
                   : load_side(o->road, runs_label("road", o->road), o->run, model, method, bms);
    // A's curves against an MF 6.1 file fitted to B's: A relative to B as MF scaling factors.
    const std::optional<RigScaling> scaling = rig_relative_to(a.tyre_curves, b.tyre_curves);
    if (!o->svg.empty()) {
      plot::XyChart c;
      c.title = fmt::format("{} vs {} ({} fits)", a.label, b.label, o->method);
      c.x_label = "slip [%]";
      c.y_label = "brake force [N]";
      const Side* sides[2] = {&a, &b};
      for (int i = 0; i < 2; ++i) {
        const Side& s = *sides[i];
        plot::Series pts{s.label + " measured",          {},   {}, true,
                         i == 0 ? "#9ecae1" : "#fcae91", false};
        for (const auto& cv : s.curves)
          for (std::size_t k = 0; k < cv.size(); k += std::max<std::size_t>(1, cv.size() / 150)) {
            pts.x.push_back(100 * cv.slip_ratio[k]);
            pts.y.push_back(cv.force_n[k]);
          }
        c.series.push_back(std::move(pts));
      }
      for (int i = 0; i < 2; ++i) {
        // Solid where the side has data, dashed beyond (extrapolated): a roller test stops at
        // 27 % slip and says nothing about 100 %.
        const Side& s = *sides[i];
        double smax = 0;
        for (const auto& cv : s.curves) smax = std::max(smax, cv.max_slip_ratio());
        const char* color = i == 0 ? "#1f77b4" : "#d62728";
        plot::Series line{fmt::format("{} fit", s.label), {}, {}, false, color, false};
        plot::Series beyond{fmt::format("{} fit beyond its data (> {:.0f} %)", s.label, 100 * smax),
                            {},
                            {},
                            false,
                            color,
                            true};
        for (int k = 0; k <= 200; ++k) {
          const double x = 0.005 * k;
          auto& target = x <= smax ? line : beyond;
          if (x > smax && beyond.x.empty() && !line.x.empty()) {  // join the two pieces
            beyond.x.push_back(line.x.back());
            beyond.y.push_back(line.y.back());
          }
          target.x.push_back(100 * x);
          target.y.push_back(mf_force_n(s.mean, x));
        }
        c.series.push_back(std::move(line));
        if (!beyond.x.empty()) c.series.push_back(std::move(beyond));
      }
      write_file(o->svg, plot::render_svg(c));
      spdlog::info("comparison plot written to {}", o->svg);
    }
    if (o->json) {
      nlohmann::ordered_json j;
      j["schema"] = "brakefit.compare/1";
      j["version"] = kVersion;
      j["model_hash"] = model.hash;
      j["method"] = o->method;
      j["a"] = side_json(a);
      j["b"] = side_json(b);
      j["ratio_b_over_a"] = {{"B", num(b.mean.B / a.mean.B)},
                             {"C", num(b.mean.C / a.mean.C)},
                             {"D", num(b.mean.D / a.mean.D)},
                             {"peak_force", num(b.peak_force_n / a.peak_force_n)}};
      j["mf61_scaling"] =
          scaling ? rig_scaling_json(*scaling, a.label, b.label) : nlohmann::ordered_json(nullptr);
      std::cout << j.dump() << "\n";
      return;
    }
    auto cell = [](double v, double u, int prec) {
      return std::isfinite(u) ? fmt::format("{:.{}f} ± {:.{}f}", v, prec, u, prec)
                              : fmt::format("{:.{}f}", v, prec);
    };
    std::cout << fmt::format(
        "Pac96 parameters: {} fit to the pooled points of each side (± standard error; "
        "[spread] = std of the per-event fits)\n",
        o->method);
    for (const Side* side : {&a, &b})
      std::cout << fmt::format(
          "  {}: {}\n", side->label,
          side->basis == "tyre"
              ? fmt::format("the tyre's curve (bench model {})", side->bench_model)
              : std::string("the instrument's force (no bench model)"));
    std::cout << fmt::format("  {:<22} {:>24} {:>24} {:>8}\n", "parameter",
                             a.label + ": " + count(a.fits.size(), "event"),
                             b.label + ": " + count(b.fits.size(), "event"), "B/A");
    const char* names[4] = {"B [1/-]", "C", "D [N]", "E"};
    const double va[4] = {a.mean.B, a.mean.C, a.mean.D, a.mean.E},
                 vb[4] = {b.mean.B, b.mean.C, b.mean.D, b.mean.E};
    const int prec[4] = {3, 4, 1, 4};  // NOLINT
    const char* keys[4] = {"B", "C", "D", "E"};
    auto bound = [&](const Side& side, std::size_t k, const std::string& text) {
      const auto& ab = side.at_bound;
      return std::find(ab.begin(), ab.end(), keys[k]) == ab.end() ? text : text + " (at bound)";
    };
    for (std::size_t k = 0; k < 4; ++k) {
      std::cout << fmt::format("  {:<22} {:>24} {:>24} {:>8.3f}\n", names[k],
                               bound(a, k, cell(va[k], a.uncertainty[k], prec[k])),
                               bound(b, k, cell(vb[k], b.uncertainty[k], prec[k])), vb[k] / va[k]);
      if (std::isfinite(a.spread[k]) || std::isfinite(b.spread[k]))
        std::cout << fmt::format("  {:<22} {:>24} {:>24}\n", "",
                                 fmt::format("[{:.{}f}]", a.spread[k], prec[k]),
                                 fmt::format("[{:.{}f}]", b.spread[k], prec[k]));
    }
    std::cout << fmt::format("  {:<22} {:>24.1f} {:>24.1f}\n", "RMSE of the fit [N]", a.rmse_n,
                             b.rmse_n);
    std::cout << fmt::format("  {:<22} {:>24.4f} {:>24.4f} {:>8.3f}\n", "B [1/%] (paper unit)",
                             a.mean.B / 100, b.mean.B / 100, b.mean.B / a.mean.B);
    std::cout << fmt::format("  {:<22} {:>24.1f} {:>24.1f} {:>8.3f}\n", "peak brake force [N]",
                             a.peak_force_n, b.peak_force_n, b.peak_force_n / a.peak_force_n);
    std::cout << fmt::format("  {:<22} {:>24.2f} {:>24.2f} {:>8.3f}\n", "slip at peak [%]",
                             100 * a.peak_slip_ratio, 100 * b.peak_slip_ratio,
                             b.peak_slip_ratio / a.peak_slip_ratio);
    for (const Side* side : {&a, &b})
      if (!side->implausible.empty())
        std::cout << fmt::format("  {}: NOT A TYRE'S CURVE: {}\n", side->label,
                                 fmt::join(side->implausible, "; "));
    if (scaling)
      std::cout << fmt::format(
          "MF 6.1 scaling factors of {} relative to a file fitted to {} (RMS {:.2f} % of peak "
          "scaled, {:.2f} % unscaled):\n{}",
          a.label, b.label, scaling->rig.rms_pct_peak, scaling->rig.unscaled_rms_pct_peak,
          factors_text(scaling->rig));
    if (scaling && !b.implausible.empty())
      std::cout << fmt::format("  ({}'s curve is not a tyre's: the factors compare instruments)\n",
                               b.label);
  });
}

}  // namespace brakefit::cli
