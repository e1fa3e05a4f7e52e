#pragma once
// Pacejka-96 "Magic Formula" for longitudinal brake force (paper Eq. 2):
//   F(x) = D sin[C arctan{B(1-E)x + E arctan(Bx)}] + SVx,  x = slip_ratio + SHx
// Slip is a ratio (0..1) and braking slip and force are positive; B is per unit slip ratio.
#include <array>
#include <span>

namespace brakefit {

struct MfParams {
  double B = 10.0;    ///< stiffness factor, per unit slip ratio
  double C = 1.5;     ///< shape factor
  double D = 1000.0;  ///< peak factor, N
  double E = 0.0;     ///< curvature factor
  double SHx = 0.0;   ///< horizontal shift, slip ratio
  double SVx = 0.0;   ///< vertical shift, N
};

inline constexpr std::size_t kMfParamCount = 6;
using MfGradient = std::array<double, kMfParamCount>;  ///< dF/d(B, C, D, E, SHx, SVx)

double mf_force_n(const MfParams& p, double slip_ratio);
/// Force and its analytic partial derivatives with respect to B, C, D, E, SHx, SVx.
double mf_force_and_gradient(const MfParams& p, double slip_ratio, MfGradient& grad);

struct MfPeak {
  double slip_ratio = 0.0;
  double force_n = 0.0;
  bool interior = false;  ///< true when the maximum lies strictly inside (0, slip_max)
};
/// Maximum of F over [0, slip_max] (dense scan plus golden-section refinement).
MfPeak mf_peak(const MfParams& p, double slip_max = 1.0);

/// Parameter vector helpers (order B, C, D, E, SHx, SVx).
std::array<double, kMfParamCount> to_array(const MfParams& p);
MfParams from_array(std::span<const double> a);

}  // namespace brakefit
