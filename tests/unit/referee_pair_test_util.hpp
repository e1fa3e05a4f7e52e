#pragma once
// The referee's pair trials (bench/gap_referee --pairs) drawn and diagnosed one at a time, for
// tests that pin what a pair the referee scores is said.
#include <cstdint>
#include <optional>
#include <string>

#include "core/gap/gap.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"

namespace brakefit::test {

/// A trial's scores and notes, one per line, for a failure's message.
inline std::string why_of(const sim::TrialResult& r) {
  std::string why;
  for (const auto& s : r.scores) why += "\n  " + s;
  for (const auto& s : r.notes) why += "\n  " + s;
  return why;
}

/// Whether a trial's verdict names the effect.
inline bool names(const sim::TrialResult& t, const std::string& effect) {
  for (const auto& v : t.verdict)
    if (v == effect) return true;
  return false;
}

/// The referee's pair trial `index` as `bench/gap_referee --pairs` draws and seeds it (seed 1),
/// diagnosed under the condition's shipped gates (or those given).
struct RefereePair {
  sim::Injection inj;
  sim::TrialResult res;
  std::string why;  ///< its scores and notes, for a failure's message
};
inline RefereePair referee_pair(gap::Condition c, sim::Generator g, int index,
                                std::optional<gap::Options> gates = std::nullopt) {
  Rng rng(sim::pair_draw_seed(1, c));
  RefereePair p;
  for (int t = 0; t <= index; ++t) p.inj = sim::draw_pair(rng, c, g);
  p.res = sim::run_trial(p.inj, sim::pair_trial_seed(1, static_cast<std::uint64_t>(index), c),
                         gates.value_or(gap::calibrated_options(c)));
  p.why = why_of(p.res);
  return p;
}

/// The gates the referee calibrates for generator B's ground sets from every export.
inline gap::Options every_export_ground_gates() {
  gap::Options gates = gap::calibrated_options(gap::Condition::Ground);
  gates.gate_gain = 0.101;
  gates.bic_margin_per_point = 0.2379;
  return gates;
}

/// Draws from every export while it lives (generator B's stations are a process-wide setting).
struct EveryExport {
  EveryExport() { sim::set_generator_b_stations(sim2::Stations::Every); }
  ~EveryExport() { sim::set_generator_b_stations(sim2::Stations::Cars); }
  EveryExport(const EveryExport&) = delete;
  EveryExport& operator=(const EveryExport&) = delete;
};

/// Generator B's ground pair `index` from every export, under the referee's gates for them.
inline RefereePair every_export_ground_pair(int index) {
  const EveryExport every;
  return referee_pair(gap::Condition::Ground, sim::Generator::B, index,
                      every_export_ground_gates());
}

/// Generator B's misspecified ground set `index` from every export (a brush-model tyre, no
/// effect), as `bench/gap_referee --misspecified` draws and seeds it.
inline sim::TrialResult every_export_misspecified_ground(int index) {
  const EveryExport every;
  sim::Injection inj;
  inj.effect = "misspecified";
  inj.condition = gap::Condition::Ground;
  inj.generator = sim::Generator::B;
  return sim::run_trial(inj, sim::misspecified_seed(static_cast<std::uint64_t>(index)),
                        every_export_ground_gates());
}

/// The referee's gates for every export's roller sets (seed 1, 20 null sets).
inline gap::Options every_export_roller_gates() {
  gap::Options gates = gap::calibrated_options(gap::Condition::Roller);
  gates.gate_gain = 0.169;
  gates.bic_margin_per_point = 0.3504;
  gates.noise_factor = 5.92;
  return gates;
}

/// The referee's roller trial `index` from every export (seed 1, null share 0.3).
inline sim::TrialResult every_export_roller_trial(int index) {
  const EveryExport every;
  Rng rng(1 + 100 * static_cast<std::uint64_t>(gap::Condition::Roller));
  sim::Injection inj;
  for (int t = 0; t <= index; ++t)
    inj = sim::draw_injection(rng, 0.3, gap::Condition::Roller, sim::Generator::B);
  return sim::run_trial(inj,
                        1000 + static_cast<std::uint64_t>(index) +
                            100'000 * static_cast<std::uint64_t>(gap::Condition::Roller),
                        every_export_roller_gates());
}

}  // namespace brakefit::test
