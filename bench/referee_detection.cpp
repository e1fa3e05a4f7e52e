#include "bench/referee_detection.hpp"

#include <fmt/format.h>

#include <cmath>
#include <iostream>
#include <vector>

#include "bench/referee_util.hpp"

namespace brakefit::bench {

nlohmann::ordered_json run_detection(gap::Condition c, sim::Generator g, const gap::Options& gates,
                                     const DetectionSettings& st, const std::string& cname) {
  struct Cell {
    std::string effect;
    double magnitude;
  };
  std::vector<Cell> cells;
  std::vector<std::string> effects;
  for (const auto& e : sim::referee_effects(c, g)) {
    if (g == sim::Generator::B && e == "load_transfer") continue;
    effects.push_back(e);
    const auto [lo, hi] = sim::effect_range(c, g, e);
    const double from = lo / 4;
    for (int k = 0; k < st.levels; ++k) {
      const double m = from * std::pow(hi / from, k / std::max(1.0, st.levels - 1.0));
      for (int s = 0; s < st.sets; ++s) cells.push_back({e, m});
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
        return sim::run_trial(inj,
                              st.seed0 * 1000 + 900'000 + static_cast<std::uint64_t>(i) +
                                  100'000 * static_cast<std::uint64_t>(c),
                              gates);
      },
      cname + " detection");
  nlohmann::ordered_json j;
  std::cout << fmt::format(
      "\ndetection ({} sets per magnitude; named: the effect in the verdict)\n", st.sets);
  std::size_t i = 0;
  for (const auto& e : effects) {
    std::string line = fmt::format("  {}:", e);
    double smallest = NAN;
    nlohmann::ordered_json curve = nlohmann::ordered_json::array();
    for (int k = 0; k < st.levels; ++k) {
      const double m = cells[i].magnitude;
      int named = 0;
      for (int s = 0; s < st.sets; ++s, ++i) named += results[i].correct();
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
