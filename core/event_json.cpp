#include "core/event_json.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "brakefit/version.hpp"

namespace brakefit {

namespace {

/// The one rule: not reached in the data, and the curve's maximum over [0, 1] is interior.
bool beyond(bool peak_reached, const MfPeak& whole) {
  return !peak_reached && whole.interior;
}

}  // namespace

nlohmann::ordered_json num(double v) {
  return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr);
}

nlohmann::ordered_json result_json(const MethodResult& r) {
  nlohmann::ordered_json j;
  j["method"] = to_string(r.method);
  j["basis"] = to_string(r.basis);
  j["B"] = num(r.params.B);
  j["C"] = num(r.params.C);
  j["D"] = num(r.params.D);
  j["E"] = num(r.params.E);
  j["mape_pct"] = num(r.metrics.mape_pct);
  j["mape_points_excluded"] = r.metrics.mape_points_excluded;
  j["rmse_n"] = num(r.metrics.rmse_n);
  j["rmse_pct_peak"] = num(r.metrics.rmse_pct_peak);
  const MfPeak pk = mf_peak(r.params, 1.0);
  j["peak_force_n"] = num(pk.force_n);
  j["peak_slip_ratio"] = num(pk.slip_ratio);
  j["peak_reached"] = r.peak_reached;
  j["peak_beyond_data"] = beyond(r.peak_reached, pk);
  j["at_bound"] = r.at_bound;
  j["implausible"] = r.implausible;  // why these cannot be a tyre's curve; empty: plausible
  if (r.stderr_) {
    const auto& s = *r.stderr_;
    j["stderr"] = {{"B", num(s[0])}, {"C", num(s[1])}, {"D", num(s[2])}, {"E", num(s[3])}};
    nlohmann::ordered_json why = nlohmann::ordered_json::object();
    const char* names[4] = {"B", "C", "D", "E"};
    for (std::size_t k = 0; k < 4; ++k)
      if (!std::isfinite(s[k]) && !r.stderr_null_reason[k].empty())
        why[names[k]] = r.stderr_null_reason[k];
    j["stderr_null_reason"] = why;
    j["converged"] = r.converged;
    j["iterations"] = r.iterations;
  } else {
    j["stderr"] = nullptr;
  }
  if (r.bmu) j["bmu"] = *r.bmu;
  return j;
}

bool peak_beyond_data(const MethodResult& r) {
  return beyond(r.peak_reached, mf_peak(r.params, 1.0));
}

std::string result_notes(const MethodResult& r) {
  std::string out;
  for (const auto& b : r.at_bound) out += (out.empty() ? "" : ", ") + b;
  if (!out.empty()) out += " at bound";
  if (peak_beyond_data(r)) out += (out.empty() ? "" : "; ") + std::string("peak beyond the data");
  if (!r.implausible.empty())
    out += fmt::format("{}NOT A TYRE'S CURVE: {}", out.empty() ? "" : "; ",
                       fmt::join(r.implausible, "; "));
  return out;
}

std::string result_notes(const std::vector<MethodResult>& results, std::size_t i) {
  auto same = [](double a, double b) {
    return std::abs(a - b) <= 1e-6 * std::max(1.0, std::abs(a));
  };
  std::string out = result_notes(results[i]);
  const MfParams& p = results[i].params;
  std::vector<std::string> alike;
  for (std::size_t j = 0; j < results.size(); ++j) {
    const MfParams& q = results[j].params;
    if (j != i && same(p.B, q.B) && same(p.C, q.C) && same(p.D, q.D) && same(p.E, q.E))
      alike.push_back(to_string(results[j].method));
  }
  if (!alike.empty())
    out += fmt::format("{}the same curve as {}", out.empty() ? "" : "; ", fmt::join(alike, ", "));
  return out;
}

nlohmann::ordered_json event_json(const pipeline::EventResult& e, const std::string& file,
                                  const Model* model) {
  nlohmann::ordered_json j;
  j["schema"] = "brakefit.event/1";
  j["version"] = kVersion;
  j["model_hash"] = model ? nlohmann::ordered_json(model->hash) : nlohmann::ordered_json(nullptr);
  j["file"] = file;
  j["event_id"] = e.event.event_id;
  j["bench"] = can::to_string(e.event.bench);
  j["t_start_ns"] = e.event.t_start_ns;
  j["t_end_ns"] = e.event.t_end_ns;
  j["end_reason"] = e.event.end_reason;
  j["flags"] = e.event.flags;
  if (!e.event.note.empty()) j["end_note"] = e.event.note;
  j["points"] = e.curve.size();
  j["max_slip_ratio"] = num(e.curve.max_slip_ratio());
  double max_force_n = std::nan("");
  for (double f : e.curve.force_n)
    max_force_n = std::isnan(max_force_n) ? f : std::max(max_force_n, f);
  j["max_force_n"] = num(max_force_n);
  j["mape_rule"] = kMapeRule;
  j["results"] = nlohmann::ordered_json::array();
  for (const auto& r : e.results) j["results"].push_back(result_json(r));
  if (!e.tyre_results.empty() || !e.tyre_notes.empty()) {
    j["tyre_results"] = nlohmann::ordered_json::array();
    for (const auto& r : e.tyre_results) j["tyre_results"].push_back(result_json(r));
    j["tyre_max_slip_ratio"] = num(e.tyre_max_slip_ratio);
    j["tyre_notes"] = e.tyre_notes;
  }
  return j;
}

}  // namespace brakefit
