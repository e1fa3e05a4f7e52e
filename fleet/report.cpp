#include "fleet/report.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <set>

#include "brakefit/version.hpp"
#include "core/plot/svg.hpp"
#include "fleet/utc_text.hpp"

namespace brakefit::fleet {

namespace {

std::string iso_date(std::int64_t t) {
  return utc_text(t, "%Y-%m-%d");
}

double num(const PgResult& r, int row, int col) {
  return r.null(row, col) ? NAN : std::stod(r.text(row, col));
}

std::string verdict_text(const fleetstats::Verdict& v, const std::string& what, int decimals) {
  const std::string lead = what.empty() ? "" : what + " ";
  if (!v.departs)
    return fmt::format("{}in line with the fleet ({} weeks compared)", lead, v.weeks_compared);
  return fmt::format("{}reads {} than the fleet since the week of {}: {:+.{}f} ({})", lead,
                     v.direction > 0 ? "higher" : "lower", iso_date(v.since_unix_s), v.offset,
                     decimals,
                     v.noise > 0 ? fmt::format("{:.1f}x its noise", std::abs(v.offset) / v.noise)
                                 : std::string("the lanes' readings have no spread"));
}

nlohmann::ordered_json verdict_json(const fleetstats::Verdict& v) {
  return {{"departs", v.departs},
          {"direction", v.direction > 0   ? "high"
                        : v.direction < 0 ? "low"
                                          : "none"},
          {"since", v.departs ? nlohmann::ordered_json(iso_date(v.since_unix_s))
                              : nlohmann::ordered_json(nullptr)},
          {"offset", v.offset},
          {"noise", v.noise},
          {"weeks_compared", v.weeks_compared}};
}

nlohmann::ordered_json weeks_json(const std::vector<fleetstats::WeekFigure>& w) {
  auto a = nlohmann::ordered_json::array();
  for (const auto& x : w)
    a.push_back({{"week", iso_date(x.week_unix_s)},
                 {"events", x.events},
                 {"median", x.median},
                 {"iqr", x.iqr}});
  return a;
}

std::string chart(const Report& r, bool friction) {
  plot::XyChart c;
  c.title = friction ? "Peak friction (D / wheel load) per lane against the fleet, weekly medians"
                     : "Slip stiffness (B C D / wheel load) per lane against the fleet, weekly "
                       "medians";
  c.x_label = "week [days since the first week]";
  c.y_label = friction ? "peak friction [-]" : "slip stiffness per wheel load [1/unit slip]";
  const auto& fleet = friction ? r.fleet_friction : r.fleet_stiffness;
  if (fleet.median.empty()) return plot::render_svg(c);
  const std::int64_t t0 = fleet.median.begin()->first;
  auto day = [t0](std::int64_t t) { return static_cast<double>(t - t0) / 86400.0; };
  plot::Series med{"fleet median", {}, {}, false, "#000000", false};
  plot::Series hi{"fleet median + 3 spread", {}, {}, false, "#7f7f7f", true};
  plot::Series lo{"fleet median - 3 spread", {}, {}, false, "#7f7f7f", true};
  for (const auto& [t, m] : fleet.median) {
    med.x.push_back(day(t));
    med.y.push_back(m);
    hi.x.push_back(day(t));
    hi.y.push_back(m + 3 * fleet.spread.at(t));
    lo.x.push_back(day(t));
    lo.y.push_back(m - 3 * fleet.spread.at(t));
  }
  c.series = {med, hi, lo};
  std::size_t k = 0;
  for (const auto& l : r.lanes) {
    const auto& v = friction ? l.friction_verdict : l.stiffness_verdict;
    plot::Series s{fmt::format("{} / {}{}", l.station, l.lane, v.departs ? " (departs)" : ""),
                   {},
                   {},
                   false,
                   plot::series_color(k++),
                   false};
    for (const auto& w : friction ? l.friction : l.stiffness) {
      s.x.push_back(day(w.week_unix_s));
      s.y.push_back(w.median);
    }
    c.series.push_back(std::move(s));
  }
  return plot::render_svg(c);
}

}  // namespace

Report build_report(Pg& pg, double weeks) {
  const auto t0 = std::chrono::steady_clock::now();
  Report rep;
  rep.weeks = weeks;
  const PgParam since = PgParam::text(fmt::format("{}", weeks * 7.0 * 86400.0));
  const std::string window = "created_at >= now() - make_interval(secs => $1::double precision)";
  std::map<std::pair<std::string, std::string>, LaneReport> lanes;
  auto lane = [&](const PgResult& r, int row) -> LaneReport& {
    auto& l = lanes[{r.text(row, 0), r.text(row, 1)}];
    l.station = r.text(row, 0);
    l.lane = r.text(row, 1);
    return l;
  };
  {
    const PgResult r =
        pg.exec("SELECT station_id, lane_id, bench, flags, count(*) FROM brakefit.events WHERE " +
                    window + " GROUP BY 1, 2, 3, 4",
                {since});
    for (int i = 0; i < r.rows(); ++i) {
      auto& l = lane(r, i);
      const auto n = std::stoll(r.text(i, 4));
      l.events += n;
      rep.events += n;
      l.benches[r.text(i, 2)] += n;
      std::string flags = r.text(i, 3);
      std::size_t pos = 0;
      while (pos < flags.size()) {
        const std::size_t end = std::min(flags.find_first_of(",| ", pos), flags.size());
        if (end > pos) l.flags[flags.substr(pos, end - pos)] += n;
        pos = end + 1;
      }
    }
  }
  // Weekly medians and quartiles per lane, on the roller where a lane has roller events (the
  // tester's own reading), else on whatever bench it has.
  {
    const PgResult r = pg.exec(
        "WITH e AS (SELECT station_id, lane_id, bench, created_at, peak_friction, "
        "slip_stiffness_n / NULLIF(wheel_load_n, 0) AS kx FROM brakefit.events WHERE " +
            window +
            " AND peak_friction IS NOT NULL), "
            "b AS (SELECT station_id, lane_id, CASE WHEN bool_or(bench = 'roller') THEN 'roller' "
            "ELSE min(bench) END AS bench FROM e GROUP BY 1, 2) "
            "SELECT e.station_id, e.lane_id, EXTRACT(EPOCH FROM date_trunc('week', "
            "e.created_at))::bigint, count(*), "
            "percentile_cont(0.5) WITHIN GROUP (ORDER BY peak_friction), "
            "percentile_cont(0.75) WITHIN GROUP (ORDER BY peak_friction) - "
            "percentile_cont(0.25) WITHIN GROUP (ORDER BY peak_friction), "
            "percentile_cont(0.5) WITHIN GROUP (ORDER BY kx), "
            "percentile_cont(0.75) WITHIN GROUP (ORDER BY kx) - "
            "percentile_cont(0.25) WITHIN GROUP (ORDER BY kx) "
            "FROM e JOIN b USING (station_id, lane_id) WHERE e.bench = b.bench "
            "GROUP BY 1, 2, 3 ORDER BY 1, 2, 3",
        {since});
    for (int i = 0; i < r.rows(); ++i) {
      auto& l = lane(r, i);
      const std::int64_t t = std::stoll(r.text(i, 2)), n = std::stoll(r.text(i, 3));
      l.friction.push_back({t, n, num(r, i, 4), num(r, i, 5)});
      l.stiffness.push_back({t, n, num(r, i, 6), num(r, i, 7)});
    }
  }
  {
    const PgResult r = pg.exec(
        "SELECT station_id, lane_id, bench, percentile_cont(0.5) WITHIN GROUP (ORDER BY "
        "peak_friction) FROM brakefit.events WHERE " +
            window + " AND peak_friction IS NOT NULL GROUP BY 1, 2, 3",
        {since});
    for (int i = 0; i < r.rows(); ++i) {
      auto& l = lane(r, i);
      (r.text(i, 2) == "roller" ? l.roller_friction : l.road_friction) = num(r, i, 3);
    }
  }
  {
    const PgResult r = pg.exec(
        "SELECT model_hash, count(*), min(created_at)::date::text, max(created_at)::date::text "
        "FROM brakefit.events WHERE " +
            window + " GROUP BY 1 ORDER BY 2 DESC",
        {since});
    for (int i = 0; i < r.rows(); ++i)
      rep.models.push_back({r.text(i, 0), std::stoll(r.text(i, 1)), r.text(i, 2), r.text(i, 3)});
  }
  std::map<std::string, std::vector<fleetstats::WeekFigure>> fr, st;
  for (auto& [k, l] : lanes) {
    fr[l.station + "\n" + l.lane] = l.friction;
    st[l.station + "\n" + l.lane] = l.stiffness;
  }
  rep.fleet_friction = fleetstats::fleet_weeks(fr);
  rep.fleet_stiffness = fleetstats::fleet_weeks(st);
  for (auto& [k, l] : lanes) {
    l.friction_verdict = fleetstats::control(l.friction, rep.fleet_friction);
    l.stiffness_verdict = fleetstats::control(l.stiffness, rep.fleet_stiffness);
    rep.lanes.push_back(std::move(l));
  }
  const auto now = std::chrono::system_clock::now();
  rep.generated =
      iso_date(std::chrono::duration_cast<std::chrono::seconds>(now.time_since_epoch()).count());
  rep.query_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

nlohmann::ordered_json report_json(const Report& r) {
  nlohmann::ordered_json j;
  j["schema"] = "brakefit.fleet_report/1";
  j["version"] = kVersion;
  j["generated"] = r.generated;
  j["weeks"] = r.weeks;
  j["events"] = r.events;
  j["query_seconds"] = r.query_seconds;
  auto lanes = nlohmann::ordered_json::array();
  for (const auto& l : r.lanes) {
    nlohmann::ordered_json x;
    x["station"] = l.station;
    x["lane"] = l.lane;
    x["events"] = l.events;
    x["benches"] = l.benches;
    x["flags"] = l.flags;
    x["peak_friction"] = {{"verdict", verdict_json(l.friction_verdict)},
                          {"weeks", weeks_json(l.friction)}};
    x["slip_stiffness_per_load"] = {{"verdict", verdict_json(l.stiffness_verdict)},
                                    {"weeks", weeks_json(l.stiffness)}};
    const bool both = std::isfinite(l.roller_friction) && std::isfinite(l.road_friction);
    x["roller_vs_road"] =
        both ? nlohmann::ordered_json{{"roller_peak_friction", l.roller_friction},
                                      {"road_peak_friction", l.road_friction},
                                      {"ratio", l.roller_friction / l.road_friction}}
             : nlohmann::ordered_json(nullptr);
    lanes.push_back(x);
  }
  j["lanes"] = lanes;
  auto models = nlohmann::ordered_json::array();
  for (const auto& m : r.models)
    models.push_back(
        {{"model_hash", m.hash}, {"events", m.events}, {"first", m.first}, {"last", m.last}});
  j["models"] = models;
  return j;
}

std::string report_text(const Report& r) {
  std::string out = fmt::format("fleet report ({}; the last {:g} weeks): {} events, {} lanes\n",
                                r.generated, r.weeks, r.events, r.lanes.size());
  for (const auto& l : r.lanes) {
    std::string flags;
    for (const auto& [f, n] : l.flags) flags += fmt::format(" {} {}", f, n);
    out += fmt::format("  {} / {}: {} events{}\n", l.station, l.lane, l.events,
                       flags.empty() ? "" : ";" + flags);
    out += "    " + verdict_text(l.friction_verdict, "peak friction", 3) + "\n";
    out += "    " + verdict_text(l.stiffness_verdict, "slip stiffness", 1) + "\n";
    if (std::isfinite(l.roller_friction) && std::isfinite(l.road_friction))
      out += fmt::format("    roller vs road peak friction: {:.3f} / {:.3f} = {:.3f}\n",
                         l.roller_friction, l.road_friction, l.roller_friction / l.road_friction);
  }
  for (const auto& m : r.models)
    out += fmt::format("  model {}: {} events, {} to {}\n", m.hash, m.events, m.first, m.last);
  return out;
}

std::vector<std::pair<std::string, std::string>> report_files(const Report& r) {
  std::string html = fmt::format(
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>brakefit fleet "
      "report</title></head><body>\n<h1>brakefit fleet report</h1>\n<p>{} events over the last "
      "{:g} weeks, {} lanes; generated {} by brakefit {}.</p>\n",
      r.events, r.weeks, r.lanes.size(), r.generated, kVersion);
  html +=
      "<h2>Lanes</h2>\n<table border=\"1\"><tr><th>station</th><th>lane</th><th>events</th>"
      "<th>flags</th><th>peak friction</th><th>slip stiffness</th><th>roller / road</th></tr>\n";
  for (const auto& l : r.lanes) {
    std::string flags;
    for (const auto& [f, n] : l.flags) flags += fmt::format("{} {}<br>", plot::xml_escape(f), n);
    const bool both = std::isfinite(l.roller_friction) && std::isfinite(l.road_friction);
    html += fmt::format(
        "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
        plot::xml_escape(l.station), plot::xml_escape(l.lane), l.events, flags,
        plot::xml_escape(verdict_text(l.friction_verdict, "", 3)),
        plot::xml_escape(verdict_text(l.stiffness_verdict, "", 1)),
        both ? fmt::format("{:.3f}", l.roller_friction / l.road_friction) : std::string("-"));
  }
  html +=
      "</table>\n<h2>Over time</h2>\n<img src=\"friction.svg\" alt=\"peak friction per lane\">"
      "\n<img src=\"stiffness.svg\" alt=\"slip stiffness per lane\">\n<h2>Models in use</h2>\n"
      "<table border=\"1\"><tr><th>model hash</th><th>events</th><th>first</th><th>last</th>"
      "</tr>\n";
  for (const auto& m : r.models)
    html += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                        plot::xml_escape(m.hash), m.events, m.first, m.last);
  html += "</table>\n</body></html>\n";
  return {
      {"index.html", html}, {"friction.svg", chart(r, true)}, {"stiffness.svg", chart(r, false)}};
}

}  // namespace brakefit::fleet
