#pragma once
// MF 6.1 results as the commands report them (tyre, compare, gap): the JSON of a fit and of a
// rig's scaling factors, and one rig relative to another from their events.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/identify.hpp"
#include "core/pipeline/calibration.hpp"
#include "core/tyre/mf61_fit.hpp"
#include "core/tyre/scaling.hpp"

namespace brakefit::cli {

/// An event's curve where it was measured (the calibration's load, pressure and speed), seeded
/// with its least-squares (else hybrid) fit when it has one.
tyre::TyreCurve tyre_curve(const std::string& source, const Curve& curve,
                           const pipeline::Calibration& cal,
                           const std::vector<MethodResult>& results);

nlohmann::ordered_json curves_json(const std::vector<tyre::CurveFit>& curves);
nlohmann::ordered_json fit_json(const tyre::Mf61FitResult& fit);
nlohmann::ordered_json factors_json(const tyre::ScalingFit& s);

/// A rig (the roller) relative to a reference (the road): the reference's MF 6.1 file and the
/// rig's LMUX, LKX, LCX, LEX against it.
struct RigScaling {
  tyre::Mf61FitResult reference;
  tyre::ScalingFit rig;
};
/// Nullopt (with a warning saying why) when either side's curves cannot be fitted.
std::optional<RigScaling> rig_relative_to(const std::vector<tyre::TyreCurve>& rig,
                                          const std::vector<tyre::TyreCurve>& reference);
/// {"reference": "...", "factors": [...], "rms_pct_peak", "unscaled_rms_pct_peak", ...}
nlohmann::ordered_json rig_scaling_json(const RigScaling& s, const std::string& rig_label,
                                        const std::string& reference_label);
/// Lines for a terminal: "  LMUX  0.9512 +- 0.004" or "  LEX  1 held: ...".
std::string factors_text(const tyre::ScalingFit& s);

}  // namespace brakefit::cli
