#include "core/fleet/control_chart.hpp"

#include <algorithm>
#include <cmath>

namespace brakefit::fleetstats {

double median_of(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

FleetWeeks fleet_weeks(const std::map<std::string, std::vector<WeekFigure>>& lanes) {
  std::map<std::int64_t, std::vector<double>> by_week;
  for (const auto& [key, weeks] : lanes)
    for (const auto& w : weeks)
      if (std::isfinite(w.median)) by_week[w.week_unix_s].push_back(w.median);
  FleetWeeks f;
  for (const auto& [t, ms] : by_week) {
    const double m = median_of(ms);
    std::vector<double> dev;
    for (double x : ms) dev.push_back(std::abs(x - m));
    f.median[t] = m;
    // 1.4826 MAD: the standard deviation of a normal spread; one lane alone has none.
    f.spread[t] = ms.size() >= 3 ? 1.4826 * median_of(dev) : 0.0;
  }
  return f;
}

Verdict control(const std::vector<WeekFigure>& lane, const FleetWeeks& fleet) {
  std::vector<WeekFigure> weeks = lane;
  std::sort(weeks.begin(), weeks.end(),
            [](const WeekFigure& a, const WeekFigure& b) { return a.week_unix_s < b.week_unix_s; });
  struct Step {
    std::int64_t t;
    double diff, noise;
    int sign;
  };
  std::vector<Step> steps;
  for (const auto& w : weeks) {
    const auto m = fleet.median.find(w.week_unix_s);
    if (m == fleet.median.end() || w.events < 1 || !std::isfinite(w.median)) continue;
    // The standard error of a median: 1.2533 sigma / sqrt(n), sigma from the IQR.
    const double se = 1.2533 * (w.iqr / 1.349) / std::sqrt(static_cast<double>(w.events));
    const double spread = fleet.spread.at(w.week_unix_s);
    const double noise = std::sqrt(se * se + spread * spread);
    const double diff = w.median - m->second;
    const int sign = std::abs(diff) > kDepartFactor * noise ? (diff > 0 ? 1 : -1) : 0;
    steps.push_back({w.week_unix_s, diff, noise, sign});
  }
  Verdict v;
  v.weeks_compared = static_cast<int>(steps.size());
  if (steps.empty() || steps.back().sign == 0) return v;
  const int dir = steps.back().sign;
  std::size_t first = steps.size() - 1;
  while (first > 0 && steps[first - 1].sign == dir) --first;
  const std::size_t run = steps.size() - first;
  if (run < static_cast<std::size_t>(kMinWeeksToFlag)) return v;
  std::vector<double> diffs, noises;
  for (std::size_t i = first; i < steps.size(); ++i) {
    diffs.push_back(steps[i].diff);
    noises.push_back(steps[i].noise);
  }
  v.departs = true;
  v.direction = dir;
  v.since_unix_s = steps[first].t;
  v.offset = median_of(diffs);
  v.noise = median_of(noises);
  return v;
}

}  // namespace brakefit::fleetstats
