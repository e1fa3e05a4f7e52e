// brakefit gap RUNS...: the sim-to-real gap of the Magic Formula on measured runs (core/gap):
// where the residual lies, which unmodelled effect explains it, how far it shrinks on withheld
// runs. JSON brakefit.gap/1 and an HTML report with the residual map and before/after curves.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <ctime>
#include <filesystem>
#include <iostream>

#include "cli/commands.hpp"
#include "cli/gap_report.hpp"
#include "cli/io.hpp"
#include "cli/recording.hpp"
#include "cli/tyre_load_laws.hpp"
#include "cli/tyre_report.hpp"
#include "core/gap/bench_model.hpp"
#include "core/gap/gap.hpp"

namespace brakefit::cli {

namespace {

/// The vehicle's load transfer declared from its geometry (--vehicle-mass, --cg-height,
/// --wheelbase): the geometry is known exactly, a diagnosed magnitude only to its standard error.
gap::BenchEffect declared_load_transfer(gap::Condition condition, const std::vector<gap::Run>& runs,
                                        double mass_kg, double cg_height_m, double wheelbase_m,
                                        bool front, const gap::Options& laws) {
  if (condition != gap::Condition::Ground)
    throw ExitError(kExitUsage,
                    "gap: --cg-height and --wheelbase describe a ground test's vehicle; these runs "
                    "are from a roller, which has no load transfer");
  if (!(mass_kg > 0 && cg_height_m > 0 && wheelbase_m > 0))
    throw ExitError(kExitUsage,
                    "gap: a declared load transfer needs --vehicle-mass, --cg-height and "
                    "--wheelbase together");
  const double fz_n = gap::median_wheel_load_n(runs);
  if (!(fz_n > 0))
    throw ExitError(kExitDataError,
                    "gap: the runs carry no wheel load (the bench calibration's wheel_load_n): "
                    "the declared load transfer cannot be put relative to it");
  return gap::declared_load_transfer(mass_kg, cg_height_m, wheelbase_m, fz_n, front,
                                     laws.tyre_load_laws, laws.tyre_load_laws_source);
}

/// The declared load transfer in the bench model, in place of any the diagnosis measured.
void hold_declared_load_transfer(gap::BenchModel& bm, const gap::BenchEffect& declared) {
  auto& effects = bm.effects;
  for (auto& e : effects)
    if (e.effect == gap::Effect::LoadTransfer) {
      spdlog::info(
          "gap: the declared load transfer (q {:.4g} per m/s^2) replaces the one the "
          "diagnosis measured ({:.4g})",
          declared.value, e.value);
      e = declared;
      return;
    }
  effects.push_back(declared);
  std::erase(bm.not_held, std::string("load_transfer"));
}

}  // namespace

void add_gap_command(CLI::App& app) {
  struct Opts {
    std::vector<std::string> files, roller, road;
    std::string report, force = "pressure", model, bench_model;
    bool json = false;
    RunOptions run;
    double gate_gain = NAN, bic_margin = NAN;  ///< NaN: the calibrated gate of the condition
    double bic_margin_per_point = NAN;         ///< NaN: none (the condition's)
    double fit_quality_factor = NAN;           ///< NaN: the condition's (1.5)
    bool realign = false;          ///< --realign-delay: a late channel read at the delay named
    double vehicle_mass_kg = 0.0;  ///< 0: not given
    double cg_height_m = 0.0, wheelbase_m = 0.0;  ///< 0: not given
    std::string axle = "front";
    std::string tir;  ///< the tyre's MF 6.1 file (empty: published tyres' load laws)
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "gap",
      "Diagnose the gap between the Magic Formula and measured runs (which effect, how much)");
  cmd->add_option("runs", o->files, "candump logs or event CSVs of one bench (several ramp rates)");
  cmd->add_option("--roller", o->roller, "bench vs bench: the roller runs (fitted)");
  cmd->add_option("--road", o->road,
                  "bench vs bench: the road runs (predicted from the roller fit; transfer effects "
                  "ranked by held-out error)");
  cmd->add_flag("--json", o->json, "print the brakefit.gap/1 document");
  cmd->add_option("--report", o->report, "directory for index.html, residual.svg, curves.svg");
  cmd->add_option("--bench", o->run.bench_file, "bench calibration TOML for candump logs");
  cmd->add_option("--bench-model", o->bench_model,
                  "write the bench's measurement model (the instrument effects named, with their "
                  "magnitudes) to this TOML, for replay/compare --bench-model");
  cmd->add_option("--force", o->force, "pressure or tester")
      ->check(CLI::IsMember({"pressure", "tester"}))
      ->capture_default_str();
  cmd->add_option("--model", o->model, "model for the start values (default: the shipped one)");
  cmd->add_option("--gate-gain", o->gate_gain,
                  "minimum held-out gain to accept an effect (default: the gate calibrated on "
                  "null data of the condition: roller, ground or roller vs road)");
  cmd->add_option("--bic-margin", o->bic_margin,
                  "minimum BIC decrease to accept an effect (default: calibrated, as the gain)");
  cmd->add_option("--bic-margin-per-point", o->bic_margin_per_point,
                  "minimum BIC decrease per point fitted, where it asks more than --bic-margin "
                  "(bench/gap_referee calibrates it on null data)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--fit-quality-factor", o->fit_quality_factor,
                  "a held-out gap above this x the noise floor is `unexplained` (default 1.5; "
                  "bench/gap_referee calibrates it on null data, as the gates)")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--realign-delay", o->realign,
                "where a time offset of 20 ms or more is named on ground runs, read the force "
                "channel that much later and diagnose the runs again (each run then keeps its "
                "curve up to its runaway): what the runs show beside the delay");
  cmd->add_option("--vehicle-mass", o->vehicle_mass_kg,
                  "the vehicle's mass in kg: load transfer is also given as the centre of "
                  "gravity's height over the wheelbase (h/L), from the runs' wheel load")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--cg-height", o->cg_height_m,
                  "with --vehicle-mass and --wheelbase (ground runs): the centre of gravity's "
                  "height in m; the diagnosis holds the vehicle's load transfer as declared in "
                  "every fit (not a candidate), as does the bench model, whose tyre fits are then "
                  "at the wheel's static load")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--wheelbase", o->wheelbase_m, "the vehicle's wheelbase in m (see --cg-height)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--axle", o->axle, "the tested wheel's axle (see --cg-height)")
      ->check(CLI::IsMember({"front", "rear"}))
      ->capture_default_str();
  cmd->add_option("--tir", o->tir,
                  "the tested tyre's MF 6.1 file (.tir): a load transfer is measured and given "
                  "(dFz/Fz, h/L) at its own load laws at the runs' wheel load, not published "
                  "tyres'")
      ->check(CLI::ExistingFile);
  cmd->callback([o] {
    const Model model = load_model(resolve_model_path(o->model));
    o->run.pipeline.fit = false;
    gap::ConditionOptions co;
    co.force =
        o->force == "tester" ? pipeline::ForceSource::Tester : pipeline::ForceSource::Pressure;
    o->run.pipeline.force = co.force;
    const bool transfer = !o->roller.empty() || !o->road.empty();
    if (transfer && (o->roller.empty() || o->road.empty() || !o->files.empty()))
      throw ExitError(kExitConfig, "gap: give either RUNS, or both --roller RUNS and --road RUNS");
    if (!transfer && o->files.empty())
      throw ExitError(kExitConfig, "gap: no runs given (RUNS, or --roller and --road)");
    Curve pooled;
    std::vector<LeftOut> left_out;
    // Every file's events are read first: how many runs the set has decides how finely each is
    // kept (gap::points_per_run), so a day of tests costs about what six runs do.
    struct Usable {
      std::string path, name;
      pipeline::Event event;
      pipeline::Calibration calibration;
    };
    auto load = [&](const std::vector<std::string>& files, bool pool,
                    std::vector<tyre::TyreCurve>& curves) {
      std::vector<Usable> usable;
      for (const auto& f : files) {
        const Run run = process_run(f, o->run, nullptr);
        leave_out_if_empty(left_out, run);
        for (const auto& e : run.events) {
          if (!e.event.fittable()) {
            leave_out(left_out, run, e.event, flagged_reason(e.event));
            continue;
          }
          curves.push_back(tyre_curve(fmt::format("{} event {}", f, e.event.event_id), e.curve,
                                      run.calibration, e.results));
          usable.push_back(
              {run.path,
               fmt::format("{}#{}", std::filesystem::path(f).stem().string(), e.event.event_id),
               e.event, run.calibration});
          if (!pool) continue;
          pooled.slip_ratio.insert(pooled.slip_ratio.end(), e.curve.slip_ratio.begin(),
                                   e.curve.slip_ratio.end());
          pooled.force_n.insert(pooled.force_n.end(), e.curve.force_n.begin(),
                                e.curve.force_n.end());
        }
      }
      gap::ConditionOptions run_co = co;
      run_co.max_points = gap::points_per_run(usable.size());
      if (usable.size() > 6)
        spdlog::info(
            "gap: {} runs, {} points each, held out in 6 blocks of consecutive runs: "
            "expect about {:.0f}x the time three runs take",
            usable.size(), run_co.max_points, gap::relative_cost(usable.size()));
      std::vector<gap::Run> runs;
      for (const auto& u : usable) {
        try {
          runs.push_back(gap::condition(u.name, u.event, u.calibration, run_co));
        } catch (const InputError& err) {
          spdlog::warn("{}: event {} left out: {}", u.path, u.event.event_id, err.what());
          left_out.push_back({u.path, u.event.event_id, err.what()});
        }
      }
      return runs;
    };
    std::vector<gap::Run> roller_runs;
    std::vector<tyre::TyreCurve> curves, roller_curves;
    std::vector<gap::Run> runs =
        transfer ? load(o->road, false, curves) : load(o->files, true, curves);
    if (transfer) roller_runs = load(o->roller, true, roller_curves);
    if (!transfer && runs.size() < 2)
      // One file with one event is a usage slip; files whose events were left out are data.
      throw ExitError(o->files.size() < 2 ? kExitUsage : kExitDataError,
                      fmt::format("gap: {} usable in {}: the diagnosis needs at least two runs "
                                  "(it checks every effect on a run it was not fitted to)",
                                  count(runs.size(), "run"), count(o->files.size(), "file")));
    if (transfer)
      spdlog::info(
          "gap: {} ({} roller, {} road), seeding the baseline with the hybrid fit of "
          "the pooled roller points",
          count(roller_runs.size() + runs.size(), "run"), roller_runs.size(), runs.size());
    else
      spdlog::info("gap: {}, seeding the baseline with the hybrid fit of the pooled points",
                   count(runs.size(), "run"));
    const MethodResult seed = run_method(Method::Hybrid, &model, pooled, fit_options_for(&model));
    // The gates calibrated on null data of this condition (runs from one bench in mode 1).
    gap::Condition condition = gap::Condition::RollerToRoad;
    if (!transfer) {
      condition = runs.empty() || runs.front().bench == can::BenchKind::Roller
                      ? gap::Condition::Roller
                      : gap::Condition::Ground;
      for (const auto& r : runs)
        if (r.bench != runs.front().bench)
          throw ExitError(kExitDataError,
                          fmt::format("gap: {} is from a {} bench and {} from a {} bench; give "
                                      "runs of one bench, or --roller and --road",
                                      runs.front().name, can::to_string(runs.front().bench), r.name,
                                      can::to_string(r.bench)));
    }
    gap::Options gap_options = gap::calibrated_options(condition);
    if (std::isfinite(o->gate_gain)) gap_options.gate_gain = o->gate_gain;
    gap_options.vehicle_mass_kg = o->vehicle_mass_kg;
    if (!o->tir.empty() && condition != gap::Condition::Ground)
      spdlog::warn("gap: --tir {}: {}; the file's laws are not used", o->tir,
                   transfer ? "roller vs road gives a load transfer at its free stiffness ratio"
                            : "a roller has no load transfer");
    else if (!o->tir.empty()) {
      gap_options.tyre_load_laws = tyre_load_laws_from(o->tir, runs);
      gap_options.tyre_load_laws_source = o->tir;
    }
    std::optional<gap::BenchEffect> declared;
    if (!transfer && (o->cg_height_m > 0 || o->wheelbase_m > 0)) {
      declared = declared_load_transfer(condition, runs, o->vehicle_mass_kg, o->cg_height_m,
                                        o->wheelbase_m, o->axle == "front", gap_options);
      gap_options.declared_load_per_decel_s2_per_m = declared->value;
      gap_options.declared_kx_load_ratio = declared->more.at(0);
    }
    if (std::isfinite(o->bic_margin)) gap_options.bic_margin = o->bic_margin;
    if (std::isfinite(o->bic_margin_per_point))
      gap_options.bic_margin_per_point = o->bic_margin_per_point;
    if (std::isfinite(o->fit_quality_factor)) gap_options.noise_factor = o->fit_quality_factor;
    gap_options.realign_late_channel = o->realign;
    spdlog::info(
        "gap: condition {}, gates: held-out gain >= {:.3f}, BIC drop >= max({:.1f}, {:.4f} per "
        "point), fit-quality factor {:.2f}",
        gap::to_string(condition), gap_options.gate_gain, gap_options.bic_margin,
        gap_options.bic_margin_per_point, gap_options.noise_factor);
    const gap::Report rep =
        transfer ? gap::diagnose_transfer(roller_runs, runs, seed.params, gap_options)
                 : gap::diagnose(runs, seed.params, gap_options);
    auto doc =
        report_json(rep, runs, roller_runs, left_out, model.hash,
                    transfer ? "roller_vs_road" : "model_vs_measurement", condition, gap_options);
    // Roller vs road in the terms a tyre file carries: the roller's MF 6.1 scaling factors
    // against a file fitted to the road runs.
    std::optional<RigScaling> scaling;
    if (transfer) {
      scaling = rig_relative_to(roller_curves, curves);
      doc["mf61_scaling"] =
          scaling ? rig_scaling_json(*scaling, "roller", "road") : nlohmann::ordered_json(nullptr);
    }
    if (!o->bench_model.empty()) {
      if (transfer)
        throw ExitError(kExitUsage,
                        "gap: --bench-model takes the runs of one bench (model vs measurement)");
      gap::BenchModel bm = gap::bench_model_from(rep, condition);
      if (declared) hold_declared_load_transfer(bm, *declared);
      bm.model_hash = model.hash;
      bm.date = iso8601_utc(static_cast<std::int64_t>(std::time(nullptr)));
      bm.runs = o->files;
      write_file(o->bench_model, gap::format_bench_model(bm));
      spdlog::info("bench model written to {}: {}{}", o->bench_model, held_effects(bm),
                   bm.not_held.empty() ? ""
                                       : fmt::format(" (not held, the tyre's or vehicle's: {})",
                                                     fmt::join(bm.not_held, ", ")));
    }
    if (!o->report.empty()) {
      write_report(o->report, rep, runs, doc);
      spdlog::info("report written to {}/index.html", o->report);
    }
    if (o->json) {
      std::cout << doc.dump() << "\n";
      return;
    }
    std::cout << fmt::format("verdict: {}\n", fmt::join(rep.verdict, ", "));
    std::cout << fmt::format(
        "held-out gap {:.1f} N -> {:.1f} N ({:.0f} % explained), noise floor {:.1f} N (force "
        "{:.1f} N, slip noise {:.2g} through the slope {:.1f} N)\n",
        rep.gap_before_rmse_n, rep.gap_after_rmse_n,
        rep.gap_before_rmse_n > 0 ? 100 * (1 - rep.gap_after_rmse_n / rep.gap_before_rmse_n) : 0.0,
        rep.noise_n, rep.floor.force_n, rep.floor.slip_sd_ratio, rep.floor.slip_n);
    // A table of scores (those `keep` takes) under its title; nothing where none is kept.
    const auto table = [](const std::string& title, const std::vector<gap::EffectScore>& scores,
                          auto keep) {
      bool header = false;
      for (const auto& e : scores) {
        if (!keep(e)) continue;
        if (!header) {
          std::cout << title
                    << fmt::format("  {:<18} {:<32} {:>9} {:>9}  {}\n", "effect", "parameters",
                                   "gain", "dBIC", "decision");
          header = true;
        }
        std::string ps;
        for (const auto& [k, v] : e.params) ps += fmt::format("{} {:.4g} ", k, v);
        const std::string bic = std::isfinite(e.delta_bic) ? fmt::format("{:>9.1f}", e.delta_bic)
                                                           : std::string("      n/a");
        std::cout << fmt::format("  {:<18} {:<32} {:>9.3f} {}  {}\n", gap::to_string(e.effect), ps,
                                 e.gain, bic, e.decision);
      }
    };
    table("each effect alone against the baseline:\n", rep.effects,
          [](const gap::EffectScore& e) { return e.round == 0; });
    table("forward selection (each scored against the model chosen before it):\n", rep.effects,
          [](const gap::EffectScore& e) { return e.round > 0; });
    if (!rep.stopping_round.empty())
      table(fmt::format("forward selection's round {}, none taken (each beside the effects it "
                        "chose before; the checks after it are in the notes):\n",
                        rep.stopping_round.front().round + 1),
            rep.stopping_round, [](const gap::EffectScore&) { return true; });
    if (!rep.pairs_tried.empty())
      std::cout << "pairs fitted together (each: the error held out, or in-sample where marked; "
                   "the gain over the baseline's; what each adds over the other alone):\n";
    for (const auto& q : rep.pairs_tried) {
      std::string ps;
      for (const auto* m : {&q.a, &q.b})
        for (const auto& [k, v] : m->params) ps += fmt::format("{} {:.4g} ", k, v);
      std::cout << fmt::format(
          "  {:<36} {:<40} {:>8.1f} N {:>7.3f} {:>7.3f} {:>7.3f}{}  {}\n",
          fmt::format("{} + {}", gap::to_string(q.a.effect), gap::to_string(q.b.effect)), ps,
          q.rmse_after_n, q.gain, q.gain_over_a, q.gain_over_b, q.in_sample ? " in-sample" : "",
          q.decision);
    }
    for (const auto& n : rep.notes) std::cout << "note: " << n << "\n";
    if (scaling)
      std::cout << fmt::format(
          "the roller as MF 6.1 scaling factors of a file fitted to the road runs (RMS {:.2f} % of "
          "peak scaled, {:.2f} % unscaled):\n{}",
          scaling->rig.rms_pct_peak, scaling->rig.unscaled_rms_pct_peak,
          factors_text(scaling->rig));
  });
}

}  // namespace brakefit::cli
