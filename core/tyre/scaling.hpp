#pragma once
// One rig relative to another as MF 6.1 scaling factors: a tyre file fitted on one rig's curves
// (the road's) is held, and LMUX (friction), LKX (slip stiffness), LCX (shape) and LEX (curvature)
// are fitted to the other rig's curves (the roller's), with standard errors. A factor the curves
// cannot identify (no curve past its peak: LCX and LEX) is held at 1 and says why.
#include <array>
#include <string>
#include <vector>

#include "core/tyre/mf61_fit.hpp"

namespace brakefit::tyre {

inline constexpr std::array<const char*, 4> kScalingNames = {"LMUX", "LKX", "LCX", "LEX"};

struct ScalingFit {
  std::array<double, 4> value{1, 1, 1, 1};  ///< LMUX, LKX, LCX, LEX
  std::array<double, 4> stderr_{NAN, NAN, NAN, NAN};
  std::array<std::string, 4> held_reason;  ///< empty where fitted
  std::vector<CurveFit> curves;            ///< the rig's curves against the scaled file
  double rms_pct_peak = 0;
  double unscaled_rms_pct_peak = 0;  ///< the same curves against the file at scalings 1
};

ScalingFit fit_scalings(const Mf61Tyre& reference, const std::vector<TyreCurve>& rig,
                        const Mf61FitOptions& options = {});

}  // namespace brakefit::tyre
