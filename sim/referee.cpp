#include "sim/referee.hpp"

#include <algorithm>
#include <cmath>

#include "core/identify.hpp"
#include "core/pipeline/pipeline.hpp"
#include "sim/simulator.hpp"

namespace brakefit::sim {

namespace {

struct Range {
  const char* effect;
  double lo, hi;
};
const std::vector<Range>& ranges() {
  static const std::vector<Range> r = {{"relaxation_length", 0.05, 0.4},
                                       {"wheel_inertia", 0.5, 3.0},
                                       {"brake_threshold", 1.0, 5.0},
                                       {"time_offset", 0.01, 0.05}};
  return r;
}

}  // namespace

const std::vector<std::string>& referee_effects() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& r : ranges()) n.push_back(r.effect);
    return n;
  }();
  return names;
}

Injection draw_injection(Rng& rng, double p_none) {
  if (rng.uniform() < p_none) return {};
  const auto& r = ranges()[rng.index(ranges().size())];
  return {r.effect, rng.uniform(r.lo, r.hi)};
}

Scenario inject(Scenario s, const Injection& inj) {
  if (inj.effect == "relaxation_length") s.effects.relaxation_length_m = inj.magnitude;
  if (inj.effect == "wheel_inertia") {
    s.effects.wheel_inertia = true;
    s.wheel_inertia_kgm2 = inj.magnitude;
  }
  if (inj.effect == "brake_threshold") s.effects.brake_threshold_bar = inj.magnitude;
  if (inj.effect == "time_offset") s.effects.time_offset_s = inj.magnitude;
  if (inj.effect == "misspecified") s.tyre.family = TyreMf61::Family::Burckhardt;
  return s;
}

std::vector<gap::Run> simulate_runs(const Scenario& base, std::uint64_t seed, MfParams* truth) {
  std::vector<gap::Run> out;
  std::uint64_t k = 0;
  for (const char* ramp : {"slow", "medium", "fast"}) {
    Scenario s = base;
    s.pedal_ramp = ramp;
    s.ramp_bar_per_s = ramp_rate_bar_per_s(ramp);
    s.seed = seed * 16 + k++;
    const SimResult r = simulate(s);
    if (truth) *truth = r.truth;
    pipeline::PipelineOptions o;
    o.fit = false;
    pipeline::Pipeline p(r.calibration, o, nullptr);
    for (const auto& f : r.frames) p.feed(f);
    p.finish();
    for (const auto& e : p.events()) {
      if (!e.event.fittable()) continue;
      try {
        out.push_back(gap::condition(ramp, e.event, r.calibration, {}));
      } catch (const InputError&) {
        // too few quasi-static samples in this run: the diagnosis works with the others
      }
    }
  }
  return out;
}

MfParams pooled_start(const std::vector<gap::Run>& runs) {
  Curve pooled;
  for (const auto& r : runs) {
    pooled.slip_ratio.insert(pooled.slip_ratio.end(), r.slip.begin(), r.slip.end());
    pooled.force_n.insert(pooled.force_n.end(), r.force_n.begin(), r.force_n.end());
  }
  return run_method(Method::Lm, nullptr, pooled).params;
}

bool TrialResult::exact() const {
  if (verdict.empty()) return false;
  if (truth.effect == "none") return verdict == std::vector<std::string>{"none"};
  return verdict.front() == truth.effect;
}

bool TrialResult::correct() const {
  if (exact()) return true;
  if (truth.effect == "misspecified")  // never an invented effect
    return !verdict.empty() && (verdict.front() == "none" || verdict.front() == "unexplained");
  if (verdict.empty() || truth.effect == "none") return false;
  for (const auto& n : notes)
    if (n.find("cannot separate") != std::string::npos &&
        n.find(verdict.front()) != std::string::npos && n.find(truth.effect) != std::string::npos)
      return true;
  return false;
}

TrialResult run_trial(const Scenario& base, const Injection& inj, std::uint64_t seed,
                      const gap::Options& o) {
  const Scenario s = inject(base, inj);
  const auto runs = simulate_runs(s, seed);
  // Blinded: the diagnosis sees the runs only (start values from a least-squares fit of their
  // pooled points, as `brakefit gap` does without a model).
  const gap::Report rep = gap::diagnose(runs, pooled_start(runs), o);
  TrialResult t;
  t.truth = inj;
  t.verdict = rep.verdict;
  t.notes = rep.notes;
  t.estimate = NAN;
  for (const auto& e : rep.effects)
    if (inj.effect == gap::to_string(e.effect)) t.estimate = e.params.front().second;
  t.gap_before_n = rep.gap_before_rmse_n;
  t.gap_after_n = rep.gap_after_rmse_n;
  t.noise_n = rep.noise_n;
  return t;
}

GateCalibration calibrate_gates(const Scenario& base, int n, std::uint64_t seed0,
                                const gap::Options& start) {
  GateCalibration g;
  g.options = start;
  gap::Options probe = start;
  probe.gate_gain = 1e9;  // accept nothing: we want the best candidate's scores on null data
  for (int i = 0; i < n; ++i) {
    const auto runs = simulate_runs(base, seed0 + static_cast<std::uint64_t>(i));
    const gap::Report rep = gap::diagnose(runs, pooled_start(runs), probe);
    double best_gain = -1e9, best_bic = 1e9;
    for (const auto& e : rep.effects) {
      best_gain = std::max(best_gain, e.gain);
      best_bic = std::min(best_bic, e.delta_bic);
    }
    g.null_best_gain.push_back(best_gain);
    g.null_best_delta_bic.push_back(best_bic);
  }
  const double max_gain = *std::max_element(g.null_best_gain.begin(), g.null_best_gain.end());
  const double min_bic =
      *std::min_element(g.null_best_delta_bic.begin(), g.null_best_delta_bic.end());
  g.options.gate_gain = std::max(start.gate_gain, 1.5 * max_gain);
  g.options.bic_margin = std::max(start.bic_margin, -1.5 * min_bic);
  return g;
}

}  // namespace brakefit::sim
