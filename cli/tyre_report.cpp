#include "cli/tyre_report.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/event_json.hpp"

namespace brakefit::cli {

tyre::TyreCurve tyre_curve(const std::string& source, const Curve& curve,
                           const pipeline::Calibration& cal,
                           const std::vector<MethodResult>& results) {
  tyre::TyreCurve tc;
  tc.source = source;
  tc.curve = curve;
  tc.op = {cal.wheel_load_n, cal.tyre_pressure_bar * 1e5, cal.speed_kmh / 3.6};
  // The least-squares fit, else the hybrid (also least squares, seeded by the SOM).
  for (const auto& r : results)
    if (r.method == Method::Lm || (r.method == Method::Hybrid && !tc.pac96)) tc.pac96 = r.params;
  return tc;
}

nlohmann::ordered_json curves_json(const std::vector<tyre::CurveFit>& curves) {
  auto a = nlohmann::ordered_json::array();
  for (const auto& c : curves)
    a.push_back({{"source", c.source},
                 {"wheel_load_n", c.op.fz_n},
                 {"tyre_pressure_bar", c.op.pressure_pa / 1e5},
                 {"speed_kmh", c.op.speed_mps * 3.6},
                 {"points", c.points},
                 {"max_slip_ratio", c.max_slip_ratio},
                 {"peak_force_n", c.peak_force_n},
                 {"rms_pct_peak", c.rms_pct_peak}});
  return a;
}

nlohmann::ordered_json fit_json(const tyre::Mf61FitResult& fit) {
  nlohmann::ordered_json j;
  j["reference"] = {{"fnomin_n", fit.tyre.ref.fnomin_n},
                    {"nompres_pa", fit.tyre.ref.nompres_pa},
                    {"longvl_mps", fit.tyre.ref.longvl_mps}};
  j["conditions"] = {{"loads", fit.loads}, {"pressures", fit.pressures}, {"speeds", fit.speeds}};
  auto coefs = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < tyre::kCoefCount; ++i) {
    const std::string reason = fit.held_reason(i);
    coefs.push_back(
        {{"name", tyre::coef_name(i)},
         {"value", fit.tyre.coef[i]},
         {"status", reason.empty() ? "fitted" : "held"},
         {"stderr", num(fit.stderr_[i])},
         {"reason", reason.empty() ? nlohmann::ordered_json() : nlohmann::ordered_json(reason)}});
  }
  j["coefficients"] = coefs;
  j["at_bound"] = fit.at_bound;
  j["rms_pct_peak"] = fit.rms_pct_peak;
  j["curves"] = curves_json(fit.curves);
  j["solves"] = fit.solves;
  j["converged"] = fit.converged;
  return j;
}

nlohmann::ordered_json factors_json(const tyre::ScalingFit& s) {
  auto a = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < tyre::kScalingNames.size(); ++i)
    a.push_back({{"name", tyre::kScalingNames[i]},
                 {"value", s.value[i]},
                 {"stderr", num(s.stderr_[i])},
                 {"status", s.held_reason[i].empty() ? "fitted" : "held"},
                 {"reason", s.held_reason[i].empty() ? nlohmann::ordered_json()
                                                     : nlohmann::ordered_json(s.held_reason[i])}});
  return {{"factors", a},
          {"rms_pct_peak", s.rms_pct_peak},
          {"unscaled_rms_pct_peak", s.unscaled_rms_pct_peak},
          {"curves", curves_json(s.curves)}};
}

std::optional<RigScaling> rig_relative_to(const std::vector<tyre::TyreCurve>& rig,
                                          const std::vector<tyre::TyreCurve>& reference) {
  try {
    RigScaling s{tyre::fit_mf61(reference), {}};
    s.rig = tyre::fit_scalings(s.reference.tyre, rig);
    return s;
  } catch (const InputError& e) {
    spdlog::warn("MF 6.1 scaling factors not computed: {}", e.what());
    return std::nullopt;
  }
}

nlohmann::ordered_json rig_scaling_json(const RigScaling& s, const std::string& rig_label,
                                        const std::string& reference_label) {
  nlohmann::ordered_json j;
  j["rig"] = rig_label;
  j["reference"] = reference_label;
  j["reference_fit_rms_pct_peak"] = s.reference.rms_pct_peak;
  const auto f = factors_json(s.rig);
  for (const auto& [k, v] : f.items()) j[k] = v;
  return j;
}

std::string factors_text(const tyre::ScalingFit& s) {
  std::string out;
  for (std::size_t i = 0; i < tyre::kScalingNames.size(); ++i)
    out += s.held_reason[i].empty()
               ? fmt::format("  {:<5} {:>8.4f}  +- {:.3g}\n", tyre::kScalingNames[i], s.value[i],
                             s.stderr_[i])
               : fmt::format("  {:<5} {:>8.4f}  held: {}\n", tyre::kScalingNames[i], s.value[i],
                             s.held_reason[i]);
  return out;
}

}  // namespace brakefit::cli
