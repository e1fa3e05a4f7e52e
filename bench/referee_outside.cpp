#include "bench/referee_outside.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <iostream>
#include <map>

#include "bench/referee_util.hpp"

namespace brakefit::bench {

nlohmann::ordered_json run_outside(gap::Condition c, sim::Generator trial_gen,
                                   const gap::Options& gates, const OutsideSettings& st,
                                   const std::string& cname) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();
  if (st.n <= 0) return j;
  if (trial_gen == sim::Generator::C || c == gap::Condition::RollerToRoad) {
    std::cerr << fmt::format(
        "[{}] sets outside the catalogue: generators A and B, roller and ground only\n", cname);
    return j;
  }
  const auto results = parallel_map<sim::TrialResult>(
      st.n, st.threads,
      [&](int t) {
        const auto i = static_cast<std::uint64_t>(t);
        return sim::run_trial(sim::draw_outside(i, c, trial_gen), sim::outside_seed(i), gates);
      },
      cname + " outside the catalogue");
  int ok = 0;
  std::map<std::string, std::pair<int, int>> by_effect;  // drawn, none or unexplained
  std::map<std::string, int> claimed;                    // the first name of each false claim
  int unexplained = 0;  // of the right: a gap left that no catalogue effect takes
  for (std::size_t k = 0; k < results.size(); ++k) {
    const auto& r = results[k];
    const bool right = r.correct();
    ok += right;
    auto& [drawn, none] = by_effect[r.truth.effect];
    ++drawn;
    none += right;
    const bool said_unexplained = right && r.verdict.front() == "unexplained";
    unexplained += said_unexplained;
    // Every false claim; an `unexplained` too (the gap the effect left), and with --why 2 all.
    if (!right || said_unexplained || st.why > 1)
      std::cerr << fmt::format(
          "[{}] outside {} ({} {:.4g}{}) said {}, gap before / floor {:.2f}, "
          "after {:.2f}\n",
          cname, k, r.truth.effect, r.truth.magnitude,
          r.truth.station.empty() ? "" : "; " + r.truth.station, fmt::join(r.verdict, ", "),
          r.gap_before_n / std::max(r.noise_n, 1e-9), r.gap_after_n / std::max(r.noise_n, 1e-9));
    if (right) continue;
    ++claimed[r.verdict.empty() ? "?" : r.verdict.front()];
    if (st.why) print_indented(r.notes);
  }
  j["counts"]["outside"] = st.n;
  j["counts"]["outside_ok"] = ok;
  j["counts"]["outside_unexplained"] = unexplained;
  for (const auto& [e, v] : by_effect)
    j["outside_effects"][e] = {{"drawn", v.first}, {"none_or_unexplained", v.second}};
  j["outside_claimed"] = claimed;
  std::cout << fmt::format("outside the catalogue: none/unexplained in {}/{} ({} unexplained);", ok,
                           st.n, unexplained);
  for (const auto& [e, v] : by_effect) std::cout << fmt::format(" {} {}/{}", e, v.second, v.first);
  if (!claimed.empty()) {
    std::cout << "; claimed:";
    for (const auto& [e, n] : claimed) std::cout << fmt::format(" {} {}", e, n);
  }
  std::cout << "\n";
  return j;
}

}  // namespace brakefit::bench
