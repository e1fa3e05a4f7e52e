#pragma once
// Least-squares fit of the Magic Formula to a measured curve (bounded LM), with standard errors
// and a flag for curves whose force peak lies beyond the data (e.g. a roller test switched off at
// 27 % slip before the peak).
#include <array>
#include <string>
#include <vector>

#include "core/curve.hpp"
#include "core/fit/lm.hpp"
#include "core/magic_formula.hpp"

namespace brakefit::fit {

struct MfBounds {
  double B_lo = 0.1, B_hi = 200.0;  ///< per unit slip ratio
  double C_lo = 0.3, C_hi = 3.0;
  double D_lo_factor = 0.0, D_hi_factor = 5.0;  ///< times the measured peak |force|
  double E_lo = -20.0, E_hi = 1.0;              ///< standard implementations clamp E <= 1
  double SHx_abs = 0.05;                        ///< slip ratio
  double SVx_abs_factor = 0.2;                  ///< times the measured peak |force|
};

struct MfFitOptions {
  bool fit_shifts = false;  ///< also fit SHx and SVx
  MfBounds bounds;
  LmOptions lm;
};

struct MfFitResult {
  MfParams params;
  std::array<double, kMfParamCount> stderr_{};  ///< NaN where not available
  double ssr = 0.0;
  double rmse_n = 0.0;
  int iterations = 0;
  bool converged = false;
  LmStatus status = LmStatus::MaxIterations;
  bool peak_reached = false;  ///< the fitted curve's maximum lies inside the data's slip range
  /// Parameters the fit ended on a bound of (names: B, C, D, E, SHx, SVx): the data did not
  /// determine them; the bound did. They have no standard error.
  std::vector<std::string> at_bound;
  /// Why a standard error is NaN (empty where there is one): at a bound, or not identifiable.
  std::array<std::string, kMfParamCount> stderr_null_reason{};
};

/// The classic fixed start: B = 10, C = 1.5, D = max force, E = 0.
MfParams classic_start(const Curve& c);
MfFitResult fit_mf(const Curve& c, const MfParams& start, const MfFitOptions& options = {});
/// True when the maximum of the curve lies strictly inside (0, slip_max).
bool peak_reached(const MfParams& p, double slip_max);

}  // namespace brakefit::fit
