#pragma once
// The fleet report: per station and lane, events and their flags; the identified peak friction
// (D / wheel load) and slip stiffness (B C D / wheel load) week by week against the fleet (a
// control chart, core/fleet/control_chart.hpp); roller vs road where a lane has both; the model
// hashes in use. The figures come from aggregate queries (weekly medians and quartiles per lane),
// so the server does the counting and the report's time grows with lanes x weeks, not events.
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "core/fleet/control_chart.hpp"
#include "fleet/pg.hpp"

namespace brakefit::fleet {

struct LaneReport {
  std::string station, lane;
  std::int64_t events = 0;
  std::map<std::string, std::int64_t> flags;  ///< flag -> events carrying it
  std::map<std::string, std::int64_t> benches;
  std::vector<fleetstats::WeekFigure> friction, stiffness;  ///< roller events (else all)
  fleetstats::Verdict friction_verdict, stiffness_verdict;
  double roller_friction = NAN, road_friction = NAN;  ///< medians, where the lane has both
};

struct Report {
  std::string generated;
  double weeks = 0;
  std::int64_t events = 0;
  std::vector<LaneReport> lanes;
  fleetstats::FleetWeeks fleet_friction, fleet_stiffness;
  struct Model {
    std::string hash;
    std::int64_t events = 0;
    std::string first, last;
  };
  std::vector<Model> models;
  double query_seconds = 0;
};

Report build_report(Pg& pg, double weeks);
nlohmann::ordered_json report_json(const Report& r);
std::string report_text(const Report& r);
/// index.html and its SVG charts, by file name.
std::vector<std::pair<std::string, std::string>> report_files(const Report& r);

}  // namespace brakefit::fleet
