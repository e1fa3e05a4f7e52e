// The referee's draws: which effects each generator injects and over which ranges, a single or a
// paired injection drawn from them, and the injection written into a scenario.
#include "sim/referee.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "sim/referee_internal.hpp"
#include "sim/simulator.hpp"

namespace brakefit::sim {

namespace {

struct Range {
  const char* effect;
  double lo, hi;
  bool either_sign = false;
};
const std::vector<Range>& ranges(gap::Condition c) {
  static const std::vector<Range> roller = {
      {"relaxation_length", 0.05, 0.4},   {"wheel_inertia", 0.5, 3.0},
      {"brake_threshold", 1.0, 5.0},      {"time_offset", 0.01, 0.05},
      {"slip_offset", 0.002, 0.01, true}, {"cradle_cap", 2400.0, 3550.0}};
  // On flat ground (40 km/h, 0.2-0.6 s stops) the same five, and load transfer and speed
  // friction (on one bench both reshape the curve mostly as a function of slip; what B, C, D, E
  // cannot absorb is what the diagnosis sees).
  static const std::vector<Range> ground = {
      {"relaxation_length", 0.1, 0.5},    {"wheel_inertia", 0.5, 3.0},
      {"brake_threshold", 1.0, 5.0},      {"time_offset", 0.005, 0.03},
      {"slip_offset", 0.002, 0.01, true}, {"load_transfer", 0.015, 0.05},
      {"speed_friction", 0.5, 2.0}};
  // cradle_cap: the cap in N, 60-90 % of the null tyre's 3 976 N peak (on the roller).
  static const std::vector<Range> transfer = {{"roller_friction", 1.1, 1.6},
                                              {"load_transfer", 0.015, 0.05},
                                              {"speed_friction", 0.3, 2.0},
                                              {"cradle_cap", 2400.0, 3550.0}};
  switch (c) {
    case gap::Condition::Roller:
      return roller;
    case gap::Condition::Ground:
      return ground;
    case gap::Condition::RollerToRoad:
      return transfer;
  }
  return roller;
}

}  // namespace

namespace detail {

/// d ln D / d ln Fz of the simulated tyre at the scenario's load: the load transfer's effect on
/// D (the diagnosis parameter) per unit of relative load change.
double d_ln_d_per_ln_fz(const Scenario& s) {
  TyreState a;
  a.fz_n = s.wheel_load_n;
  a.pressure_bar = s.tyre_pressure_bar;
  TyreState b = a;
  b.fz_n *= 1.01;
  return std::log(pac96_equivalent(s.tyre, b).D / pac96_equivalent(s.tyre, a).D) / std::log(1.01);
}

tyre::LoadLaws load_laws(const Scenario& s) {
  TyreState a;
  a.fz_n = s.wheel_load_n / 1.005;
  a.pressure_bar = s.tyre_pressure_bar;
  TyreState b = a;
  b.fz_n = s.wheel_load_n * 1.005;
  const MfParams lo = pac96_equivalent(s.tyre, a), hi = pac96_equivalent(s.tyre, b);
  const double dln = std::log(b.fz_n / a.fz_n);
  tyre::LoadLaws l;
  l.peak_exponent = std::log(hi.D / lo.D) / dln;
  l.kx_over_peak = std::log(hi.B * hi.C * hi.D / (lo.B * lo.C * lo.D)) / dln / l.peak_exponent;
  l.e_per_peak_scale = (hi.E - lo.E) / dln / l.peak_exponent;
  return l;
}

/// A relaxation (sigma / V) or a time offset: at one speed, one lag.
bool is_lag(const std::string& e) {
  return e == "relaxation_length" || e == "time_offset";
}

}  // namespace detail

Scenario referee_null(can::BenchKind bench) {
  Scenario s;
  s.bench = bench;
  s.effects = Effects{};
  s.effects.wheel_inertia = true;
  s.wheel_inertia_kgm2 = 0.005;
  s.effects.pressure_noise_bar = 0.05;
  return s;
}

const char* to_string(Generator g) {
  switch (g) {
    case Generator::A:
      return "A";
    case Generator::B:
      return "B";
    case Generator::C:
      return "C";
  }
  return "?";
}

namespace {

/// Generator C's effects and ranges (its own: the magnitudes in its units, converted by its
/// runner). Roller: four; ground: those, wheel inertia, load transfer (h/L) and speed friction.
std::vector<Range> outside_ranges(gap::Condition c) {
  std::vector<Range> out = {{"relaxation_length", 0.15, 0.40},
                            {"time_offset", 0.03, 0.10},
                            {"brake_threshold", 1.0, 5.0},
                            {"slip_offset", 0.005, 0.02}};
  if (c == gap::Condition::Ground)
    out.insert(
        out.end(),
        {{"wheel_inertia", 0.9, 1.5}, {"load_transfer", 0.17, 0.28}, {"speed_friction", 0.8, 1.5}});
  return out;
}

/// Generator B has no cradle (its roller bench holds the wheel on one roller).
std::vector<Range> ranges(gap::Condition c, Generator g) {
  if (g == Generator::C)
    return c == gap::Condition::RollerToRoad ? std::vector<Range>{} : outside_ranges(c);
  std::vector<Range> out;
  for (const auto& r : ranges(c))
    if (g == Generator::A || std::string(r.effect) != "cradle_cap") out.push_back(r);
  return out;
}

}  // namespace

const std::vector<std::string>& referee_effects(gap::Condition c, Generator g) {
  static const auto names = [] {
    std::vector<std::vector<std::string>> n(9);
    for (auto gen : {Generator::A, Generator::B, Generator::C})
      for (auto cond :
           {gap::Condition::Roller, gap::Condition::Ground, gap::Condition::RollerToRoad})
        for (const auto& r : ranges(cond, gen))
          n[static_cast<std::size_t>(cond) + 3 * static_cast<std::size_t>(gen)].push_back(r.effect);
    return n;
  }();
  return names[static_cast<std::size_t>(c) + 3 * static_cast<std::size_t>(g)];
}

Injection draw_injection(Rng& rng, double p_none, gap::Condition c, Generator g) {
  Injection inj;
  inj.condition = c;
  inj.generator = g;
  if (rng.uniform() < p_none) return inj;
  const auto rs = ranges(c, g);
  const auto& r = rs[rng.index(rs.size())];
  inj.effect = r.effect;
  inj.magnitude = rng.uniform(r.lo, r.hi);
  if (r.either_sign && rng.uniform() < 0.5) inj.magnitude = -inj.magnitude;
  return inj;
}

std::pair<double, double> effect_range(gap::Condition c, Generator g, const std::string& effect) {
  for (const auto& r : ranges(c, g))
    if (effect == r.effect) return {r.lo, r.hi};
  throw InputError(fmt::format("the referee draws no {} in {} from generator {}", effect,
                               gap::to_string(c), to_string(g)));
}

namespace {

/// Generator C's pairs: two of its effects whose ranges share a magnitude (its script gives the
/// set one magnitude, bench/gen_c_pair.py), and not both lags.
std::vector<std::pair<Range, Range>> outside_pairs(gap::Condition c) {
  const auto rs = ranges(c, Generator::C);
  std::vector<std::pair<Range, Range>> out;
  for (std::size_t i = 0; i < rs.size(); ++i)
    for (std::size_t k = i + 1; k < rs.size(); ++k)
      if (std::max(rs[i].lo, rs[k].lo) < std::min(rs[i].hi, rs[k].hi) &&
          !(detail::is_lag(rs[i].effect) && detail::is_lag(rs[k].effect)))
        out.emplace_back(rs[i], rs[k]);
  return out;
}

}  // namespace

bool draws_pairs(gap::Condition c, Generator g) {
  if (c == gap::Condition::RollerToRoad) return false;
  return g != Generator::C || !outside_pairs(c).empty();
}

Injection draw_pair(Rng& rng, gap::Condition c, Generator g) {
  Injection inj;
  inj.condition = c;
  inj.generator = g;
  if (g == Generator::C) {
    const auto pairs = outside_pairs(c);
    if (pairs.empty())
      throw InputError(
          fmt::format("generator C draws no pairs in {}: no two of its effects "
                      "share a magnitude",
                      gap::to_string(c)));
    const auto& [r1, r2] = pairs[rng.index(pairs.size())];
    inj.effect = r1.effect;
    inj.effect2 = r2.effect;
    inj.magnitude = inj.magnitude2 = rng.uniform(std::max(r1.lo, r2.lo), std::min(r1.hi, r2.hi));
    return inj;
  }
  const auto rs = ranges(c, g);
  if (rs.size() < 2) return inj;
  auto magnitude = [&](const Range& r) {
    const double m = rng.uniform(r.lo, r.hi);
    return r.either_sign && rng.uniform() < 0.5 ? -m : m;
  };
  const auto& r1 = rs[rng.index(rs.size())];
  const Range* r2 = &r1;
  while (r2->effect == r1.effect || (detail::is_lag(r1.effect) && detail::is_lag(r2->effect)))
    r2 = &rs[rng.index(rs.size())];
  inj.effect = r1.effect;
  inj.magnitude = magnitude(r1);
  inj.effect2 = r2->effect;
  inj.magnitude2 = magnitude(*r2);
  return inj;
}

Injection draw_outside(std::uint64_t index, gap::Condition c, Generator g) {
  Injection inj;
  inj.condition = c;
  inj.generator = g;
  Rng rng(outside_seed(index) * 7 + 3);
  if (index % 2 == 0) {
    inj.effect = "pressure_bow";
    inj.magnitude = rng.uniform(0.005, 0.03) * (rng.uniform() < 0.5 ? -1 : 1);
  } else {
    inj.effect = "friction_fade";
    inj.magnitude = rng.uniform(0.2, 1.5);
  }
  return inj;
}

namespace {

void inject_one(Scenario& s, const std::string& effect, double magnitude) {
  if (effect == "relaxation_length") s.effects.relaxation_length_m = magnitude;
  if (effect == "wheel_inertia") {
    s.effects.wheel_inertia = true;
    s.wheel_inertia_kgm2 = magnitude;
  }
  if (effect == "brake_threshold") s.effects.brake_threshold_bar = magnitude;
  if (effect == "time_offset") s.effects.time_offset_s = magnitude;
  // Measured slip 1 - (1 + e) Vw / Vref = k - e (1 - k): an offset of -e (the (1 - k) part is a
  // slip scale, which B takes).
  if (effect == "slip_offset") s.effects.wheel_radius_error_ratio = -magnitude;
  if (effect == "load_transfer") {
    // dFz / Fz = m h / (2 L W) x deceleration (one axle's share on the tested wheel), and D follows
    // Fz with the tyre's own load sensitivity.
    s.effects.load_transfer = true;
    s.cg_height_m = magnitude / detail::d_ln_d_per_ln_fz(s) * 2.0 * s.wheelbase_m * s.wheel_load_n /
                    s.vehicle_mass_kg;
  }
  if (effect == "speed_friction") s.effects.speed_friction = magnitude;
  if (effect == "roller_friction") s.effects.roller_friction = 1.0 / magnitude;
  if (effect == "cradle_cap") s.effects.cradle_cap_ratio = magnitude / s.wheel_load_n;
  if (effect == "pressure_bow") s.effects.pressure_bow_ratio = magnitude;
  if (effect == "friction_fade") s.effects.fade_per_m = magnitude;
  if (effect == "misspecified") s.tyre.family = TyreMf61::Family::Burckhardt;
}

}  // namespace

Scenario inject(Scenario s, const Injection& inj) {
  inject_one(s, inj.effect, inj.magnitude);
  if (inj.pair()) inject_one(s, inj.effect2, inj.magnitude2);
  return s;
}

double Injection::load_transfer_magnitude() const {
  if (effect == "load_transfer") return magnitude;
  if (effect2 == "load_transfer") return magnitude2;
  return NAN;
}

}  // namespace brakefit::sim
