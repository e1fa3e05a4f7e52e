#include "bench/referee_pairs.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <vector>

#include "bench/referee_util.hpp"

namespace brakefit::bench {

namespace {

/// Where a pair was missed, what the pair search said of the true pair (its first rule failed),
/// or why it had none to say.
std::string true_pair_fate(const sim::TrialResult& r) {
  if (r.pairs_tried.empty()) {
    const auto said = std::count_if(r.verdict.begin(), r.verdict.end(), [](const std::string& v) {
      return v != "unexplained" && v != "none";
    });
    return said >= 3 ? "no pair searched: three effects named"
                     : "no pair searched: what selection left under the fit-quality factor x the "
                       "floor";
  }
  const auto twin = [&](const std::string& e) {
    if (!r.one_speed) return e;
    return e == "time_offset" ? std::string("relaxation_length") : e;
  };
  const std::string x = twin(r.truth.effect), y = twin(r.truth.effect2);
  for (const auto& q : r.pairs_tried) {
    const std::string a = twin(q.a), b = twin(q.b);
    if (!((a == x && b == y) || (a == y && b == x))) continue;
    switch (q.rule) {
      case gap::PairRule::Named:
        return "named by the search, undone after it";
      case gap::PairRule::AnotherNamed:
        return "another pair named first";
      case gap::PairRule::ShareOfGap:
        return "under the share of the gap a pair must explain";
      case gap::PairRule::GainOverSelection:
        return "not the gain gate below what selection left";
      case gap::PairRule::BicMargin:
        return "under twice the BIC margin";
      case gap::PairRule::MemberGain:
        return "a member adds under the gain gate";
      case gap::PairRule::RangeEnd:
        return "a member on its range's end";
      case gap::PairRule::OverFloor:
        return "in-sample over the fit-quality factor x the floor";
      case gap::PairRule::Evidence:
        return "a member without the evidence only it leaves";
    }
  }
  return "the true pair not fitted";
}

}  // namespace

nlohmann::ordered_json run_pairs(gap::Condition c, sim::Generator trial_gen,
                                 const gap::Options& gates, const PairSettings& st,
                                 const std::string& cname) {
  nlohmann::ordered_json j;
  // Their own draws (the single-effect trials' draws and seeds stay as they were).
  Rng rng(sim::pair_draw_seed(st.seed0, c));
  std::vector<sim::Injection> draws;
  std::vector<int> kept;
  const auto wanted = [&](const std::string& e) {
    return std::find(st.only.begin(), st.only.end(), e) != st.only.end();
  };
  for (int t = 0; t < st.n; ++t) {
    draws.push_back(sim::draw_pair(rng, c, trial_gen));
    const bool picked =
        st.pick.empty() || std::find(st.pick.begin(), st.pick.end(), t) != st.pick.end();
    if (picked && (st.only.empty() || wanted(draws.back().effect) || wanted(draws.back().effect2)))
      kept.push_back(t);
  }
  const int n = static_cast<int>(kept.size());
  const auto results = parallel_map<sim::TrialResult>(
      n, st.threads,
      [&](int k) {
        const auto t = static_cast<std::uint64_t>(kept[static_cast<std::size_t>(k)]);
        return sim::run_trial(draws[t], sim::pair_trial_seed(st.seed0, t, c), gates);
      },
      cname + " pairs");
  int both = 0, exact = 0, refused = 0;
  // Per effect: in how many pairs it was drawn and named; its magnitude error where named.
  std::map<std::string, int> drawn, named;
  std::map<std::string, std::vector<double>> err;
  // Per effect not named by its own name: with a reach, and below it (beside the effects named).
  std::map<std::string, std::pair<int, int>> not_named;
  std::vector<double> load_ratio_err;  // load transfer as dFz/Fz per m/s^2, where named
  std::map<std::string, int> fate;     // each missed pair: what the search said of the true pair
  for (std::size_t k = 0; k < results.size(); ++k) {
    const auto& r = results[k];
    const auto& inj = r.truth;
    both += r.correct();
    exact += r.exact();
    refused += !r.verdict.empty() && r.verdict.front() == "refused";
    for (const auto& [e, m, est, reach] :
         {std::tuple{inj.effect, inj.magnitude, r.estimate, r.reach},
          std::tuple{inj.effect2, inj.magnitude2, r.estimate2, r.reach2}}) {
      ++drawn[e];
      const bool said = std::find(r.verdict.begin(), r.verdict.end(), e) != r.verdict.end();
      named[e] += said;
      if (said && std::isfinite(est)) err[e].push_back(std::abs(est - m) / std::abs(m));
      if (!said) {
        not_named[e].first += !std::isnan(reach);
        not_named[e].second += std::abs(m) < reach;
      }
    }
    if (!r.correct()) ++fate[true_pair_fate(r)];
    if (std::isfinite(r.load_per_decel_estimate) && std::isfinite(inj.load_per_decel))
      load_ratio_err.push_back(std::abs(r.load_per_decel_estimate / inj.load_per_decel - 1));
    if (!r.correct() || st.why > 1)
      std::cerr << fmt::format(
          "[{}] pair {}: {} {:.4g} + {} {:.4g} said {} (estimates {:.4g}, {:.4g})\n", cname,
          kept[k], inj.effect, inj.magnitude, inj.effect2, inj.magnitude2,
          fmt::join(r.verdict, ", "), r.estimate, r.estimate2);
    if ((!r.correct() && st.why) || st.why > 1) {
      print_indented(r.notes);
      print_indented(r.scores);
    }
  }
  std::cout << fmt::format(
      "\npairs: both named {}/{} ({:.1f} %), exactly the two {}/{}, refused {}\n", both, n,
      100.0 * both / std::max(1, n), exact, n, refused);
  std::cout << "\n| effect in a pair | drawn | named | magnitude error where named: median, p90 "
               "| not named: below what the runs could show beside the effects named "
               "|\n|---|---|---|---|---|\n";
  for (const auto& [e, d] : drawn) {
    const auto& v = err[e];
    std::cout << fmt::format("| {} | {} | {} | {:.1f} %, {:.1f} % | {} of {} |\n", e, d, named[e],
                             100 * quantile(v, 0.5), 100 * quantile(v, 0.9), not_named[e].second,
                             d - named[e]);
    j["pair_effects"][e] = {{"drawn", d},
                            {"named", named[e]},
                            {"not_named_with_reach", not_named[e].first},
                            {"not_named_below_reach", not_named[e].second},
                            {"magnitude_error_named_median", quantile(v, 0.5)},
                            {"magnitude_error_named_p90", quantile(v, 0.9)}};
  }
  if (!fate.empty()) {
    std::cout << "\npairs missed, what the pair search said of the true pair:\n";
    for (const auto& [why, count] : fate) std::cout << fmt::format("- {}: {}\n", why, count);
  }
  j["pairs_missed_true_pair"] = fate;
  j["counts"] = {{"pairs", n}, {"pairs_both", both}, {"pairs_exact", exact}};
  if (!load_ratio_err.empty()) {
    j["pair_load_ratio_error_named"] = {{"median", quantile(load_ratio_err, 0.5)},
                                        {"trials", load_ratio_err.size()}};
    std::cout << fmt::format("load transfer in a pair as dFz/Fz per m/s^2: median {:.1f} % ({})\n",
                             100 * quantile(load_ratio_err, 0.5), load_ratio_err.size());
  }
  j["pair_trials"] = n;
  j["pairs_both_named"] = n ? static_cast<double>(both) / n : NAN;
  j["pairs_exact"] = n ? static_cast<double>(exact) / n : NAN;
  j["pairs_refused"] = refused;
  return j;
}

}  // namespace brakefit::bench
