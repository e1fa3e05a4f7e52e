#include "core/gap/bench_model.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "core/gap/internal.hpp"
#include "core/toml_reader.hpp"

namespace brakefit::gap {

namespace {
/// One order for a model's effects (the catalogue's): TOML tables come back sorted by name.
void sort_effects(BenchModel& m) {
  std::stable_sort(m.effects.begin(), m.effects.end(),
                   [](const BenchEffect& a, const BenchEffect& b) { return a.effect < b.effect; });
}
/// A named load transfer is held at its measured magnitude (the stiffness's load ratio at the
/// tyre's load laws), not at the free fit's: the free ratio can end far from any tyre's (0.38 on
/// a ground set whose only effect was the wheel's inertia, where undoing the free fit's q put the
/// tyre 30 % off), while q at the held ratio is what the report gives as the magnitude.
void hold_measured_load_transfer(const Report& rep, BenchEffect& b) {
  for (const auto& sc : rep.effects) {
    if (sc.effect != Effect::LoadTransfer || !sc.accepted) continue;
    const auto ps = effect_params(Effect::LoadTransfer);  // magnitude, ratio, pitch lag, mode
    double q = NAN, lag_s = 0.0, mode_s2 = 0.0, ratio = kPublishedKxLoadRatio;
    for (const auto& [name, v] : sc.params) {
      if (name == ps[0].name) q = v;
      if (name == "kx_load_ratio_held") ratio = v;
      if (name == ps[2].name) lag_s = v;
      if (name == ps[3].name) mode_s2 = v;
    }
    if (!std::isfinite(q)) return;
    b.value = q;
    b.stderr_ = NAN;  // the free fit's covariance is not this magnitude's
    b.more = {ratio, lag_s, mode_s2};
    b.origin = fmt::format(
        "measured by the diagnosis, the slip stiffness's load ratio held at the tyre's load "
        "laws' {:.2f}",
        ratio);
    return;
  }
}

}  // namespace

bool is_bench_effect(Effect e, Condition c) {
  switch (e) {
    case Effect::RelaxationLength:
    case Effect::TimeOffset:
    case Effect::WheelInertia:
    case Effect::BrakeThreshold:
    case Effect::SlipOffset:
      return true;
    case Effect::LoadTransfer:
      return c == Condition::Ground;
    default:
      return false;
  }
}

BenchEffect declared_load_transfer(double vehicle_mass_kg, double cg_height_m, double wheelbase_m,
                                   double wheel_load_n, bool front_axle, const tyre::LoadLaws& laws,
                                   const std::string& laws_source) {
  const double dfz_per_fz = (front_axle ? 1.0 : -1.0) * vehicle_mass_kg * cg_height_m /
                            (2.0 * wheelbase_m * wheel_load_n);
  BenchEffect b;
  b.effect = Effect::LoadTransfer;
  b.value = dfz_per_fz * laws.peak_exponent;
  b.stderr_ = NAN;
  b.more = {laws.kx_over_peak, 0.0, 0.0};
  b.origin = fmt::format(
      "declared from the vehicle: {:.0f} kg, centre of gravity {:.3f} m high, wheelbase {:.3f} m, "
      "{} axle, wheel load {:.0f} N: dFz/Fz {:.4g} per m/s^2, D by {:.2f} of it (d ln D / d ln "
      "Fz), the slip stiffness's load ratio {:.2f}, both {}",
      vehicle_mass_kg, cg_height_m, wheelbase_m, front_axle ? "front" : "rear", wheel_load_n,
      dfz_per_fz, laws.peak_exponent, laws.kx_over_peak,
      laws_source.empty() ? std::string("published tyres'")
                          : "the tyre's own (" + laws_source + ")");
  return b;
}

BenchModel bench_model_from(const Report& rep, Condition c) {
  BenchModel m;
  m.condition = to_string(c);
  std::size_t at = 4;
  for (Effect e : rep.accepted) {
    const std::size_t first = at;
    at += effect_params(e).size();
    if (is_nuisance(e)) continue;
    if (!is_bench_effect(e, c)) {
      m.not_held.emplace_back(to_string(e));
      continue;
    }
    BenchEffect b;
    b.effect = e;
    b.value = rep.after.params.at(first);
    b.stderr_ = first < rep.after.stderr_.size() ? rep.after.stderr_[first] : NAN;
    // The runs' disagreement where it is larger than the fit's own error (fold_spread).
    if (first < rep.after_spread.size() && std::isfinite(rep.after_spread[first]))
      b.stderr_ = std::isfinite(b.stderr_) ? std::max(b.stderr_, rep.after_spread[first])
                                           : rep.after_spread[first];
    for (std::size_t j = first + 1; j < at; ++j) b.more.push_back(rep.after.params.at(j));
    if (e == Effect::LoadTransfer) hold_measured_load_transfer(rep, b);
    m.effects.push_back(b);
  }
  return m;
}

std::string format_bench_model(const BenchModel& in) {
  BenchModel m = in;
  sort_effects(m);
  std::string out = "# A bench's measurement model, written by brakefit gap --bench-model\n";
  out += fmt::format("# model hash {}, {}, from {} run(s):\n", m.model_hash,
                     m.date.empty() ? "undated" : m.date, m.runs.size());
  for (const auto& r : m.runs) out += fmt::format("#   {}\n", r);
  out += "schema = \"brakefit.bench_model\"\nversion = 1\n";
  out += fmt::format("condition = \"{}\"\n", m.condition);
  out += "# named, but the tyre's or the vehicle's: not undone\nnot_held = [";
  for (std::size_t i = 0; i < m.not_held.size(); ++i)
    out += fmt::format("{}\"{}\"", i ? ", " : "", m.not_held[i]);
  out += "]\n";
  for (const auto& e : m.effects) {
    const auto ps = effect_params(e.effect);
    out += "\n";
    if (!e.origin.empty()) out += fmt::format("# {}\n", e.origin);
    out += fmt::format("[effects.{}]\n{} = {:.9g}\n", to_string(e.effect), ps[0].name, e.value);
    out += std::isfinite(e.stderr_) ? fmt::format("{}_stderr = {:.3g}\n", ps[0].name, e.stderr_)
                                    : "# standard error not known (the fit's covariance was not)\n";
    for (std::size_t j = 0; j < e.more.size() && j + 1 < ps.size(); ++j)
      out += fmt::format("{} = {:.9g}\n", ps[j + 1].name, e.more[j]);
  }
  return out;
}

BenchModel parse_bench_model(std::string_view text, const std::string& source) {
  const toml::table t = parse_toml(text, source);
  const TomlReader rd(source);
  rd.check_keys(t, "", {"schema", "version", "condition", "not_held", "effects"});
  BenchModel m;
  if (t["schema"].value_or(std::string()) != "brakefit.bench_model")
    rd.fail("schema", "expected \"brakefit.bench_model\" (is this a bench model?)");
  if (t["version"].value_or(std::int64_t{0}) != 1) rd.fail("version", "expected 1");
  m.condition = t["condition"].value_or(std::string());
  if (m.condition != "roller" && m.condition != "ground")
    rd.fail("condition", "expected \"roller\" or \"ground\"");
  if (const auto* nh = t["not_held"].as_array())
    for (const auto& v : *nh) m.not_held.push_back(v.value_or(std::string("?")));
  const auto* effects = t["effects"].as_table();
  if (!effects) return m;
  for (const auto& [name, node] : *effects) {
    const std::string key = "effects." + std::string(name.str());
    Effect e{};
    bool found = false;
    for (Effect cand : {Effect::RelaxationLength, Effect::TimeOffset, Effect::WheelInertia,
                        Effect::BrakeThreshold, Effect::SlipOffset, Effect::LoadTransfer})
      if (name.str() == to_string(cand)) {
        e = cand;
        found = true;
      }
    if (!found || !node.is_table())
      rd.fail(key,
              "not an effect a bench model holds (relaxation_length, time_offset, "
              "wheel_inertia, brake_threshold, slip_offset, and on the ground load_transfer)");
    if (e == Effect::LoadTransfer && m.condition != "ground")
      rd.fail(key,
              "load transfer is the vehicle's pitch on the ground; this model's condition is " +
                  m.condition);
    const auto& et = *node.as_table();
    const auto ps = effect_params(e);
    const std::string param = ps[0].name, err = param + "_stderr";
    const std::string prefix = key + ".";
    std::set<std::string> keys{param, err};
    for (std::size_t j = 1; j < ps.size(); ++j) keys.emplace(ps[j].name);
    rd.check_keys(et, prefix, keys);
    if (!et.contains(param)) rd.fail(fmt::format("{}{}", prefix, param), "missing");
    BenchEffect b;
    b.effect = e;
    b.value = rd.number(et, prefix, ps[0].name, 0.0, ps[0].lo, ps[0].hi);
    b.stderr_ = rd.number(et, prefix, err.c_str(), NAN, 0.0, 1e9);
    if (e == Effect::LoadTransfer)  // optional: the published ratio, no lag, no pitch mode
      b.more = {rd.number(et, prefix, ps[1].name, kPublishedKxLoadRatio, ps[1].lo, ps[1].hi),
                rd.number(et, prefix, ps[2].name, 0.0, ps[2].lo, ps[2].hi),
                rd.number(et, prefix, ps[3].name, 0.0, ps[3].lo, ps[3].hi)};
    m.effects.push_back(b);
  }
  sort_effects(m);
  return m;
}

TyrePoints tyre_points(const Run& r, const BenchModel& m) {
  const std::size_t n = r.t_s.size();
  double sigma_m = 0, dt_s = 0, inertia = 0, p0_bar = 0, offset = 0;
  double load_q = 0, load_ratio = kPublishedKxLoadRatio, pitch_lag_s = 0, pitch_mode_s2 = 0;
  for (const auto& e : m.effects) {
    if (e.effect == Effect::LoadTransfer) {
      load_q = e.value;
      if (e.more.size() >= 2) {
        load_ratio = e.more[0];
        pitch_lag_s = e.more[1];
      }
      if (e.more.size() >= 3) pitch_mode_s2 = e.more[2];
    }
    if (e.effect == Effect::RelaxationLength) sigma_m = e.value;
    if (e.effect == Effect::TimeOffset) dt_s = e.value;
    if (e.effect == Effect::WheelInertia) inertia = e.value;
    if (e.effect == Effect::BrakeThreshold) p0_bar = e.value;
    if (e.effect == Effect::SlipOffset) offset = e.value;
  }
  // The slip side as predict() takes it: transient slip, less the offset, read dt earlier.
  std::vector<double> slip = r.slip;
  if (sigma_m > 0) slip = relax(r, slip, sigma_m, 0.0);
  for (double& s : slip) s -= offset;
  TyrePoints out;
  std::size_t past_end = 0;
  const double threshold_n = r.brake_gain_n_per_bar * p0_bar;
  const double r2 = r.wheel_radius_m * r.wheel_radius_m;
  // The wheel's load relative to its static one, as predict() has it.
  std::vector<double> load(n, 1.0);
  if (load_q != 0) {
    const std::vector<double> decel = pitch_lagged_decel(r, pitch_lag_s, pitch_mode_s2);
    for (std::size_t i = 0; i < n; ++i) load[i] = std::max(0.05, 1.0 + load_q * decel[i]);
  }
  for (std::size_t i = 0; i < n; ++i) {
    const double at = r.t_s[i] - dt_s;
    if (at > r.t_s.back()) {
      ++past_end;
      continue;
    }
    const double s = at >= r.t_s.front()
                         ? interp(r.t_s, slip, at)
                         : std::max(slip.front() + r.initial_slip_rate_per_s * (at - r.t_s.front()),
                                    std::min(slip.front(), 0.0));
    // The wheel's inertial force is in the channel as late as the tyre's force (as predict()).
    const double accel = r.wheel_accel_mps2.empty() ? 0.0 : interp(r.t_s, r.wheel_accel_mps2, at);
    // A declared pressure filter (the exporting software's first order) undone: the line's
    // pressure leads the channel by tau times its rate, and a fast ground ramp is tens of bar/s
    // per 10 ms.
    const double line_n = line_force_n(r, i);
    out.curve.slip_ratio.push_back(s * std::pow(load[i], load_ratio - 1.0));
    // Below the threshold the pads give no torque: the channel reads up to p0 while the tyre
    // carries only the wheel's inertial force (predict's min(threshold, force), undone).
    out.curve.force_n.push_back((line_n + inertia * accel / r2 - std::min(threshold_n, line_n)) /
                                load[i]);
  }
  if (r.runaway)
    out.left_out.emplace_back(
        fmt::format("the wheel's lock-up runaway from {:.1f} % slip on (a step in the wheel's "
                    "speed: no quasi-static force)",
                    100 * r.slip.back()),
        0);
  if (past_end)
    out.left_out.emplace_back(
        fmt::format("the force channel's lead ({:.3f} s) past the run's end", -dt_s), past_end);
  return out;
}

}  // namespace brakefit::gap
