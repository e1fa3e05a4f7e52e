#include "bench/referee_detection.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <vector>

#include "bench/referee_util.hpp"

namespace brakefit::bench {

namespace {

/// A set that did not name its effect: what it said, its gap against its floor and the smallest
/// magnitude its runs could have shown (the report's reach, where it gives one).
void print_miss(const std::string& cname, std::size_t set, const sim::TrialResult& r, int why) {
  const double floor_n = std::max(r.noise_n, 1e-9);
  std::cerr << fmt::format(
      "[{} detection] set {}: {} {:.4g} said {}{} (gap before / floor {:.2f}, after {:.2f}){}\n",
      cname, set, r.truth.effect, r.truth.magnitude, fmt::join(r.verdict, ", "),
      r.truth.station.empty() ? "" : " [" + r.truth.station + "]", r.gap_before_n / floor_n,
      r.gap_after_n / floor_n,
      std::isnan(r.reach) ? std::string() : fmt::format(", reach {:.4g}", r.reach));
  if (!why) return;
  print_indented(r.notes);
  print_indented(r.scores);
}

}  // namespace

nlohmann::ordered_json run_detection(gap::Condition c, sim::Generator g, const gap::Options& gates,
                                     const DetectionSettings& st, const std::string& cname) {
  struct Cell {
    std::string effect;
    double magnitude;
    std::uint64_t set;  ///< its index among every effect's cells: --only keeps its seed
  };
  std::vector<Cell> cells;
  std::vector<std::string> effects;
  std::uint64_t set = 0;
  for (const auto& e : sim::referee_effects(c, g)) {
    const bool kept =
        st.only.empty() || std::find(st.only.begin(), st.only.end(), e) != st.only.end();
    if (kept) effects.push_back(e);
    const auto [lo, hi] = sim::effect_range(c, g, e);
    const double from = lo / 4;
    for (int k = 0; k < st.levels; ++k) {
      const double m = from * std::pow(hi / from, k / std::max(1.0, st.levels - 1.0));
      for (int s = 0; s < st.sets; ++s, ++set)
        if (kept) cells.push_back({e, m, set});
    }
  }
  const auto results = parallel_map<sim::TrialResult>(
      static_cast<int>(cells.size()), st.threads,
      [&](int i) {
        const Cell& cell = cells[static_cast<std::size_t>(i)];
        sim::Injection inj;
        inj.effect = cell.effect;
        inj.magnitude = cell.magnitude;
        inj.condition = c;
        inj.generator = g;
        inj.load_given = true;  // generator B's vehicle would otherwise set its own
        return sim::run_trial(
            inj, st.seed0 * 1000 + 900'000 + cell.set + 100'000 * static_cast<std::uint64_t>(c),
            gates);
      },
      cname + " detection");
  nlohmann::ordered_json j;
  std::cout << fmt::format(
      "\ndetection ({} sets per magnitude; named: the effect first in the verdict, or a note "
      "that it cannot be told from the name first)\n",
      st.sets);
  std::size_t i = 0;
  for (const auto& e : effects) {
    std::string line = fmt::format("  {}:", e);
    double smallest = NAN;
    nlohmann::ordered_json curve = nlohmann::ordered_json::array();
    for (int k = 0; k < st.levels; ++k) {
      const double m = cells[i].magnitude;
      int named = 0;
      for (int s = 0; s < st.sets; ++s, ++i) {
        const sim::TrialResult& r = results[i];
        named += r.correct();
        if (!r.correct()) print_miss(cname, cells[i].set, r, st.why);
      }
      const double share = static_cast<double>(named) / st.sets;
      if (share >= 0.9 && !std::isfinite(smallest)) smallest = m;
      if (share < 0.9) smallest = NAN;  // the smallest from which on every larger one is seen
      line += fmt::format(" {:.3g}: {}/{}", m, named, st.sets);
      curve.push_back({{"magnitude", m}, {"named", named}, {"sets", st.sets}});
    }
    std::cout << line
              << (std::isfinite(smallest)
                      ? fmt::format("; named in 90 % from {:.3g}\n", smallest)
                      : std::string("; not named in 90 % up to the range's end\n"));
    j[e] = {{"curve", curve}, {"smallest_named_90", smallest}};
  }
  return {{"detection", j}};
}

}  // namespace brakefit::bench
