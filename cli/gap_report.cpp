// What `brakefit gap` writes of a diagnosis: its brakefit.gap/1 JSON, and the HTML report with
// the residual map and the curves before and after the named effects.
#include "cli/gap_report.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstring>

#include "brakefit/version.hpp"
#include "cli/io.hpp"
#include "core/event_json.hpp"
#include "core/plot/svg.hpp"

namespace brakefit::cli {

namespace {

/// One row of the effects' table: an effect's score (gap.json's shape) at its stage.
std::string effect_row(const nlohmann::ordered_json& e) {
  std::string ps;  // "name = value" per parameter, not raw JSON
  for (const auto& [k, v] : e["params"].items())
    ps += fmt::format("{}{} = {}", ps.empty() ? "" : ", ", k,
                      v.is_number() ? fmt::format("{:.4g}", v.get<double>()) : "n/a");
  // A pair at the end of a range was not scored: its numbers are null.
  const auto cell = [](const nlohmann::ordered_json& v, int digits) {
    return v.is_number() ? fmt::format("{:.{}f}", v.get<double>(), digits) : std::string("n/a");
  };
  return fmt::format(
      "<tr{}><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
      "<td>{}</td><td>{}</td></tr>\n",
      e["accepted"].get<bool>() ? " class=\"ok\"" : "", e["name"].get<std::string>(),
      plot::xml_escape(e["stage"].get<std::string>()), plot::xml_escape(ps),
      cell(e["heldout_rmse_before_n"], 1), cell(e["heldout_rmse_after_n"], 1), cell(e["gain"], 3),
      e["delta_bic"].is_number()   ? fmt::format("{:.1f}", e["delta_bic"].get<double>())
      : e["delta_bic"].is_string() ? e["delta_bic"].get<std::string>()
                                   : std::string("(found on the roller runs)"),
      plot::xml_escape(e["decision"].get<std::string>()));
}

/// A pair the pair search fitted, as a row of the same table (gap.json's pairs_tried shape).
std::string pair_row(const nlohmann::ordered_json& q) {
  nlohmann::ordered_json e;
  const auto names = q["names"].get<std::vector<std::string>>();
  e["name"] = fmt::format("{}", fmt::join(names, " + "));
  e["stage"] = q["judged"] == "in_sample" ? "pair search, in-sample" : "pair search, held out";
  nlohmann::ordered_json params;
  for (const auto& [effect, ps] : q["params"].items())
    for (const auto& [k, v] : ps.items()) params[k] = v;
  e["params"] = params;
  e["heldout_rmse_before_n"] = q["rmse_before_n"];
  e["heldout_rmse_after_n"] = q["rmse_after_n"];
  e["gain"] = q["gain"];
  e["delta_bic"] = q["delta_bic"].is_number() ? q["delta_bic"] : nlohmann::ordered_json("n/a");
  e["accepted"] = q["accepted"];
  std::string adds;
  for (const auto& [effect, g] : q["gain_over_the_other_alone"].items())
    adds += fmt::format("{}{} {}", adds.empty() ? "" : ", ", effect,
                        g.is_number() ? fmt::format("{:.3f}", g.get<double>()) : "n/a");
  e["decision"] = fmt::format("{} (each adds over the other alone: {})",
                              q["decision"].get<std::string>(), adds);
  return effect_row(e);
}

nlohmann::ordered_json params_json(const gap::Fit& f, const std::vector<gap::Effect>& effects) {
  nlohmann::ordered_json j;
  const auto names = gap::param_names(effects);
  nlohmann::ordered_json se;
  for (std::size_t i = 0; i < f.params.size() && i < names.size(); ++i) {
    const std::string& name = names[i];
    j[name] = num(f.params[i]);
    se[name] = i < f.stderr_.size() ? num(f.stderr_[i]) : nullptr;
  }
  j["stderr"] = se;
  return j;
}

}  // namespace

nlohmann::ordered_json report_json(const gap::Report& r, const std::vector<gap::Run>& runs,
                                   const std::vector<gap::Run>& roller_runs,
                                   const std::vector<LeftOut>& left_out,
                                   const std::string& model_hash, const std::string& mode,
                                   gap::Condition condition, const gap::Options& gates) {
  nlohmann::ordered_json j;
  j["schema"] = "brakefit.gap/1";
  j["version"] = kVersion;
  j["model_hash"] =
      model_hash.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(model_hash);
  j["mode"] = mode;
  j["condition"] = gap::to_string(condition);
  j["gates"] = {{"gain", num(gates.gate_gain)},
                {"bic_margin", num(gates.bic_margin)},
                {"bic_margin_per_point", num(gates.bic_margin_per_point)},
                {"fit_quality_factor", num(gates.noise_factor)},
                {"min_gap_over_floor", num(gates.min_gap_over_floor)}};
  // The load laws a load transfer is measured at: the tyre's own file's, or published tyres'.
  j["tyre_load_laws"] = {{"source", gates.tyre_load_laws_source.empty()
                                        ? nlohmann::ordered_json("published")
                                        : nlohmann::ordered_json(gates.tyre_load_laws_source)},
                         {"peak_load_exponent", num(gates.tyre_load_laws.peak_exponent)},
                         {"kx_load_ratio", num(gates.tyre_load_laws.kx_over_peak)},
                         {"e_per_peak_scale", num(gates.tyre_load_laws.e_per_peak_scale)}};
  j["runs"] = nlohmann::ordered_json::array();
  for (const auto& run : runs) j["runs"].push_back(run.name);
  if (mode == "roller_vs_road") {  // "runs" are the road's, checked against the roller's fit
    j["roller_runs"] = nlohmann::ordered_json::array();
    for (const auto& run : roller_runs) j["roller_runs"].push_back(run.name);
  }
  j["left_out"] = left_out_json(left_out);
  j["verdict"] = r.verdict;
  const auto scores_json = [&](const std::vector<gap::EffectScore>& scores, bool stopped) {
    auto out = nlohmann::ordered_json::array();
    for (const auto& e : scores) {
      nlohmann::ordered_json x;
      x["name"] = gap::to_string(e.effect);
      nlohmann::ordered_json p;
      for (const auto& [k, v] : e.params) p[k] = num(v);
      x["params"] = p;
      x["heldout_rmse_before_n"] = num(e.heldout_rmse_before_n);
      x["heldout_rmse_after_n"] = num(e.heldout_rmse_after_n);
      x["gain"] = num(e.gain);
      x["delta_bic"] = num(e.delta_bic);
      x["accepted"] = e.accepted;
      x["stage"] = e.round == 0 ? std::string("alone")
                                : fmt::format("forward selection round {}{}", e.round + 1,
                                              stopped ? ", none taken" : "");
      x["decision"] = e.decision;
      out.push_back(x);
    }
    return out;
  };
  j["effects"] = scores_json(r.effects, false);
  // Where forward selection stopped after naming an effect: what each candidate did beside it.
  j["stopping_round"] = scores_json(r.stopping_round, true);
  // Where the pair search ran: each pair fitted together, and why it was or was not named.
  j["pairs_tried"] = nlohmann::ordered_json::array();
  for (const auto& q : r.pairs_tried) {
    nlohmann::ordered_json x, params, adds;
    for (const auto* m : {&q.a, &q.b}) {
      nlohmann::ordered_json p;
      for (const auto& [k, v] : m->params) p[k] = num(v);
      params[gap::to_string(m->effect)] = p;
    }
    adds[gap::to_string(q.a.effect)] = num(q.gain_over_a);
    adds[gap::to_string(q.b.effect)] = num(q.gain_over_b);
    x["names"] = {gap::to_string(q.a.effect), gap::to_string(q.b.effect)};
    x["params"] = params;
    x["judged"] = q.in_sample ? "in_sample" : "held_out";
    x["rmse_before_n"] = num(q.rmse_before_n);
    x["rmse_after_n"] = num(q.rmse_after_n);
    x["gain"] = num(q.gain);
    x["gain_over_the_other_alone"] = adds;
    x["delta_bic"] = num(q.delta_bic);
    x["accepted"] = q.accepted;
    x["rule"] = gap::to_string(q.rule);
    x["decision"] = q.decision;
    j["pairs_tried"].push_back(x);
  }
  j["where"] = nlohmann::ordered_json::array();
  for (const auto& w : r.where)
    j["where"].push_back(
        {{"region", w.region}, {"rms_residual_n", num(w.rms_residual_n)}, {"share", num(w.share)}});
  j["noise_n"] = num(r.noise_n);
  // The floor's two parts: the force channel, and the slip noise through the local slope.
  j["floor"] = {{"total_n", num(r.floor.total_n())},
                {"force_n", num(r.floor.force_n)},
                {"slip_n", num(r.floor.slip_n)},
                {"slip_sd_ratio", num(r.floor.slip_sd_ratio)},
                {"v_ref_sd_mps", num(r.floor.v_ref_sd_mps)},
                {"v_wheel_sd_mps", num(r.floor.v_wheel_sd_mps)},
                {"v_ref_step_mps", num(r.floor.v_ref_step_mps)},
                {"v_wheel_step_mps", num(r.floor.v_wheel_step_mps)},
                {"force_step_n", num(r.floor.force_step_n)},
                {"borrowed_runs", r.floor.borrowed_runs},
                {"borrowed_speed_noise_mps", num(r.floor.borrowed_speed_noise_mps)},
                {"pooled_noise", r.floor.pooled_noise}};
  j["gap_before_rmse_n"] = num(r.gap_before_rmse_n);
  j["gap_after_rmse_n"] = num(r.gap_after_rmse_n);
  j["fraction_explained"] =
      num(r.gap_before_rmse_n > 0 ? 1.0 - r.gap_after_rmse_n / r.gap_before_rmse_n : 0.0);
  // For each one-parameter candidate not named: the smallest magnitude the runs could have
  // shown, keyed by effect, in its parameter's unit (null: nothing of it could be shown).
  j["reach"] = nlohmann::ordered_json::object();
  for (const auto& x : r.reach)
    j["reach"][gap::to_string(x.effect)] = {{gap::effect_param(x.effect).name, num(x.smallest)}};
  j["parameters_before"] = params_json(r.before, r.baseline_effects);
  j["parameters_after"] = params_json(r.after, r.accepted);
  j["notes"] = r.notes;
  return j;
}

void write_report(const std::string& dir, const gap::Report& r, const std::vector<gap::Run>& runs,
                  const nlohmann::ordered_json& doc) {
  make_output_dir(dir);
  const bool transfer = doc["mode"] == "roller_vs_road";
  // Residual map: baseline residual against slip, one series per run.
  plot::XyChart res{transfer ? "Road runs minus the roller's fit (the roller-to-road gap)"
                             : "Residual of the 4-parameter fit (measured - model)",
                    "slip [%]",
                    "residual [N]",
                    {},
                    800,
                    450};
  plot::XyChart curves{transfer ? "Road runs, the roller's fit and the corrected model"
                                : "Measured runs, baseline and corrected model",
                       "slip [%]",
                       "brake force [N]",
                       {},
                       800,
                       500};
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const auto& run = runs[k];
    const auto before = gap::predict(run, r.before.params, r.baseline_effects);
    const auto after = gap::predict(run, r.after.params, r.accepted);
    plot::Series s{run.name, {}, {}, true, plot::series_color(k)};
    plot::Series m{run.name + " measured", {}, {}, true, plot::series_color(k)};
    plot::Series b{run.name + " baseline", {}, {}, false, plot::series_color(k), true};
    plot::Series a{run.name + " corrected", {}, {}, false, plot::series_color(k)};
    for (std::size_t i = 0; i < run.slip.size(); ++i) {
      const double x = 100 * run.slip[i];
      s.x.push_back(x);
      s.y.push_back(run.force_n[i] - before[i]);
      m.x.push_back(x);
      m.y.push_back(run.force_n[i]);
      b.x.push_back(x);
      b.y.push_back(before[i]);
      a.x.push_back(x);
      a.y.push_back(after[i]);
    }
    res.series.push_back(std::move(s));
    curves.series.push_back(std::move(m));
    curves.series.push_back(std::move(b));
    if (!r.accepted.empty()) curves.series.push_back(std::move(a));
  }
  write_file(dir + "/residual.svg", plot::render_svg(res));
  write_file(dir + "/curves.svg", plot::render_svg(curves));
  write_file(dir + "/gap.json", doc.dump(2) + "\n");
  std::string rows;
  for (const auto& e : doc["effects"]) rows += effect_row(e);
  for (const auto& e : doc["stopping_round"]) rows += effect_row(e);
  for (const auto& q : doc["pairs_tried"]) rows += pair_row(q);
  // The same residual cut three ways (slip region, phase of the stop, run): one group each, so
  // each group's shares sum to 100 % (in one list they summed to 300 %).
  std::string where;
  const std::array<std::pair<const char*, const char*>, 3> groups{
      {{"", "by slip region"}, {"phase:", "by phase of the stop"}, {"run:", "by run"}}};
  for (const auto& [prefix, title] : groups) {
    std::string rows_of_group;
    for (const auto& w : r.where) {
      const bool in =
          *prefix ? w.region.rfind(prefix, 0) == 0 : w.region.find(':') == std::string::npos;
      if (!in) continue;
      rows_of_group += fmt::format("<tr><td>{}</td><td>{:.1f}</td><td>{:.1f} %</td></tr>\n",
                                   plot::xml_escape(w.region.substr(std::strlen(prefix))),
                                   w.rms_residual_n, 100 * w.share);
    }
    if (!rows_of_group.empty())
      where += fmt::format("<tr><th colspan=\"3\">{}</th></tr>\n{}", title, rows_of_group);
  }
  std::string notes;
  for (const auto& n : r.notes) notes += "<li>" + plot::xml_escape(n) + "</li>\n";
  const std::string html = fmt::format(
      R"(<!doctype html>
<html><head><meta charset="utf-8"><title>brakefit gap report</title>
<style>body{{font-family:sans-serif;max-width:900px;margin:2em auto}}table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}}td:first-child{{text-align:left}}
tr.ok{{background:#e6f4e6}}</style></head><body>
<h1>Sim-to-real gap: {}</h1>
<p>{}</p>
<h2>Verdict: {}</h2>
<p>Held-out gap (leave one run out): <b>{:.1f} N</b> before, <b>{:.1f} N</b> after ({:.0f} % explained);
noise floor {:.1f} N (force channel {:.1f} N, slip noise through the slope {:.1f} N). Condition <b>{}</b>: an effect is accepted when its held-out gain is at
least {:.3f} and its BIC drops by at least {:.1f} (gates calibrated on null data of this
condition).</p>
<ul>{}</ul>
<h2>Which effect (each candidate alone on the baseline, forward selection, the pairs fitted together)</h2>
<table><tr><th>effect</th><th>stage</th><th>parameters</th><th>held-out before [N]</th><th>after [N]</th><th>gain</th><th>ΔBIC</th><th>decision</th></tr>
{}</table>
<h2>Where the baseline misses</h2>
<table><tr><th>region</th><th>RMS residual [N]</th><th>share of the squared residual (each group sums to 100 %)</th></tr>
{}</table>
<h2>Residual map</h2><img src="residual.svg" alt="residual map">
<h2>Before and after</h2><img src="curves.svg" alt="curves">
<p>JSON: <a href="gap.json">gap.json</a> (brakefit.gap/1, brakefit {})</p>
</body></html>
)",
      doc["mode"] == "roller_vs_road" ? "the roller fit predicting the road runs"
                                      : "model vs measurement",
      plot::xml_escape(
          doc.contains("roller_runs")
              ? fmt::format("Roller runs (fitted): {}. Road runs (predicted): {}.",
                            fmt::join(doc["roller_runs"].get<std::vector<std::string>>(), ", "),
                            fmt::join(doc["runs"].get<std::vector<std::string>>(), ", "))
              : fmt::format("Runs: {}.",
                            fmt::join(doc["runs"].get<std::vector<std::string>>(), ", "))),
      plot::xml_escape(fmt::format("{}", fmt::join(r.verdict, ", "))), r.gap_before_rmse_n,
      r.gap_after_rmse_n,
      r.gap_before_rmse_n > 0 ? 100 * (1 - r.gap_after_rmse_n / r.gap_before_rmse_n) : 0.0,
      r.noise_n, r.floor.force_n, r.floor.slip_n, doc["condition"].get<std::string>(),
      doc["gates"]["gain"].get<double>(), doc["gates"]["bic_margin"].get<double>(), notes, rows,
      where, kVersion);
  write_file(dir + "/index.html", html);
}

}  // namespace brakefit::cli
