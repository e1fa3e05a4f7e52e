#pragma once
// A lane against the fleet, week by week (pure: figures in, verdict out). Each week a lane's median
// (of peak friction, say) is set against the fleet's median of lane medians that week. The noise
// of that difference is the lane's own (its weekly median's standard error, from its interquartile
// range and count) together with how much lanes differ from one another that week (the robust
// spread of the lane medians: vehicles and tyres differ between lanes). A week departs when the
// difference exceeds three times that noise; a lane departs when its latest weeks, at least
// kMinWeeksToFlag of them in a row, depart the same way, and "since" is the first of them.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace brakefit::fleetstats {

struct WeekFigure {
  std::int64_t week_unix_s = 0;  ///< the week's start
  std::int64_t events = 0;
  double median = 0, iqr = 0;
};

inline constexpr int kMinWeeksToFlag = 2;
inline constexpr double kDepartFactor = 3.0;

struct Verdict {
  bool departs = false;
  int direction = 0;              ///< +1 reads high, -1 low
  std::int64_t since_unix_s = 0;  ///< the first week of the departing run
  double offset = 0;              ///< median difference from the fleet over the run
  double noise = 0;               ///< median noise over the run
  int weeks_compared = 0;
};

/// lanes: lane key -> its weeks (any order). Returns each lane's verdict and, per week, the
/// fleet's median and spread (for the charts).
struct FleetWeeks {
  std::map<std::int64_t, double> median, spread;
};
FleetWeeks fleet_weeks(const std::map<std::string, std::vector<WeekFigure>>& lanes);
Verdict control(const std::vector<WeekFigure>& lane, const FleetWeeks& fleet);

double median_of(std::vector<double> v);

}  // namespace brakefit::fleetstats
