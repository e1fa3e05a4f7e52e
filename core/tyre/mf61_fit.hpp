#pragma once
// The joint fit of MF 6.1's pure longitudinal coefficients over many brake curves, each at its own
// wheel load, inflation pressure and speed (Ceres Solver: bounds, automatic derivatives, a Huber
// loss). Seeded from each curve's Pacejka-96 fit. A coefficient the data cannot identify is held at
// its stated default, with the reason, never invented:
//   - structurally: one load (no load laws), two loads (no quadratic or exponential load term), one
//     pressure (no pressure laws), two pressures (no quadratic pressure terms), one speed (no
//     slip-speed decay LMUV), braking slip only (PEX4), no curve past its force peak (shape PCX1
//     and curvature PEX*);
//   - statistically: after a fit, the free coefficient whose standard error is the largest share
//     of its plausible range is held when that share exceeds `identifiable_share`, and the fit is
//     repeated until every free coefficient is pinned down.
#include <optional>
#include <string>
#include <vector>

#include "core/curve.hpp"
#include "core/magic_formula.hpp"
#include "core/tyre/mf61.hpp"

namespace brakefit::tyre {

/// One brake curve: braking slip (ratio) and braking force (N), both positive, where it was
/// measured, and (optionally) its own Pacejka-96 fit, the seed.
struct TyreCurve {
  std::string source;  ///< e.g. "runs/a.log event 3"
  Curve curve;
  OperatingPoint op;
  std::optional<MfParams> pac96;
};

struct Mf61FitOptions {
  double fnomin_n = NAN;    ///< NaN: the median of the curves' loads
  double nompres_pa = NAN;  ///< NaN: the median of the curves' pressures
  double longvl_mps = 16.7;
  /// A coefficient is identified when its standard error is below this share of its range.
  double identifiable_share = 0.1;
  /// Curves whose loads (pressures, speeds) differ by less than this share are one condition.
  double same_condition_share = 0.05;
  int max_iterations = 200;
};

struct HeldCoef {
  std::size_t index = 0;
  double value = 0;
  std::string reason;
};

struct CurveFit {
  std::string source;
  OperatingPoint op;
  std::size_t points = 0;
  double max_slip_ratio = 0;
  double peak_force_n = 0;  ///< the data's largest force
  double rms_pct_peak = 0;  ///< RMS residual of the joint fit, % of peak_force_n
};

struct Mf61FitResult {
  Mf61Tyre tyre;
  CoefVector stderr_{};               ///< NaN for held coefficients
  std::vector<HeldCoef> held;         ///< in the order they were held
  std::vector<std::string> at_bound;  ///< free coefficients that ended on their range's edge
  std::vector<CurveFit> curves;
  double rms_pct_peak = 0;                           ///< over all curves, each weighted equally
  std::size_t loads = 0, pressures = 0, speeds = 0;  ///< distinct conditions
  int solves = 0;
  int iterations = 0;
  bool converged = false;
  bool held_at(std::size_t i) const;
  /// Why coefficient i is held (empty: it was fitted).
  std::string held_reason(std::size_t i) const;
};

/// The fit works on at most this many points a curve: a 1 kHz event's thousands of points are
/// averaged in groups of neighbours in slip (the curve is smooth on that scale; the averaging only
/// takes noise out). Each curve's RMS is reported on all its points.
inline constexpr std::size_t kMaxFitPoints = 200;
Curve thin_curve(const Curve& c, std::size_t max_points);

/// Each curve's own Pacejka-96 fit (the given one, else a least-squares fit from the classic
/// start).
std::vector<MfParams> pac96_fits(const std::vector<TyreCurve>& curves);
/// True when some curve's data goes on past its fitted force peak by a fifth of the peak's slip.
bool any_curve_past_peak(const std::vector<TyreCurve>& curves, const std::vector<MfParams>& pac);
/// Each curve's RMS distance from the tyre (with scalings), % of the curve's peak.
std::vector<CurveFit> evaluate_curves(const Mf61Tyre& t, const std::vector<TyreCurve>& curves,
                                      const Scalings<double>& s = {});
/// The curves' RMS figures combined, each curve weighted equally.
double overall_rms_pct(const std::vector<CurveFit>& curves);

/// Throws InputError when there is no curve, or a curve has fewer than 8 points or a non-positive
/// load, pressure or speed.
Mf61FitResult fit_mf61(const std::vector<TyreCurve>& curves, const Mf61FitOptions& options = {});

}  // namespace brakefit::tyre
