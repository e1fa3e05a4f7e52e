#include "core/tyre/scaling.hpp"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <cmath>

#include "core/tyre/covariance.hpp"

namespace brakefit::tyre {

namespace {

constexpr double kLo = 0.2, kHi = 5.0;
/// A factor is identified when its standard error is below a tenth of the unit factor.
constexpr double kIdentifiedStderr = 0.1;

struct ScaledPoint {
  const Mf61Tyre* tyre;
  OperatingPoint op;
  double slip_ratio, force_n, weight;
  template <typename T>
  bool operator()(const T* f, T* r) const {
    std::array<T, kCoefCount> c;
    for (std::size_t i = 0; i < kCoefCount; ++i) c[i] = T(tyre->coef[i]);
    const Scalings<T> s{f[0], f[1], f[2], f[3]};
    r[0] = (-mf61_fx<T>(c.data(), tyre->ref, op, -slip_ratio, s) - force_n) / weight;
    return true;
  }
};

}  // namespace

ScalingFit fit_scalings(const Mf61Tyre& reference, const std::vector<TyreCurve>& rig,
                        const Mf61FitOptions& options) {
  if (rig.empty()) throw InputError("scaling fit: no curves");
  ScalingFit out;
  std::vector<ScaledPoint> points;
  for (const auto& tc : rig) {
    const Curve thin = thin_curve(tc.curve, kMaxFitPoints);
    const double w =
        std::max(tc.curve.peak_abs_force_n(), 1e-9) * std::sqrt(static_cast<double>(thin.size()));
    for (std::size_t k = 0; k < thin.size(); ++k)
      points.push_back({&reference, tc.op, thin.slip_ratio[k], thin.force_n[k], w});
  }
  std::array<bool, 4> held{};
  if (!any_curve_past_peak(rig, pac96_fits(rig)))
    for (std::size_t i : {2u, 3u}) {
      held[i] = true;
      out.held_reason[i] = "no curve goes past its force peak: the shape beyond it is unmeasured";
    }
  std::array<double, 4> f{1, 1, 1, 1};
  for (;;) {
    ceres::Problem problem;
    for (const auto& p : points)
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<ScaledPoint, 1, 4>(new ScaledPoint(p)), nullptr,
          f.data());
    std::vector<int> fixed;
    for (int i = 0; i < 4; ++i)
      if (held[static_cast<std::size_t>(i)]) fixed.push_back(i);
    if (fixed.size() == 4) break;
    if (!fixed.empty()) problem.SetManifold(f.data(), new ceres::SubsetManifold(4, fixed));
    for (int i = 0; i < 4; ++i) {
      problem.SetParameterLowerBound(f.data(), i, kLo);
      problem.SetParameterUpperBound(f.data(), i, kHi);
    }
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = options.max_iterations;
    so.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);

    std::vector<std::size_t> free;
    for (std::size_t i = 0; i < 4; ++i)
      if (!held[i]) free.push_back(i);
    const auto m = static_cast<Eigen::Index>(points.size());
    Eigen::MatrixXd j(m, static_cast<Eigen::Index>(free.size()));
    Eigen::VectorXd r(m);
    using Jet = ceres::Jet<double, 4>;
    std::array<Jet, 4> x;
    for (std::size_t i = 0; i < 4; ++i) x[i] = Jet(f[i], static_cast<int>(i));
    for (Eigen::Index k = 0; k < m; ++k) {
      Jet e;
      points[static_cast<std::size_t>(k)](x.data(), &e);
      r(k) = e.a;
      for (std::size_t q = 0; q < free.size(); ++q)
        j(k, static_cast<Eigen::Index>(q)) = e.v(static_cast<Eigen::Index>(free[q]));
    }
    const Eigen::VectorXd se = scaled_standard_errors(j, r);
    std::size_t worst = 4;
    double worst_se = kIdentifiedStderr;
    for (std::size_t q = 0; q < free.size(); ++q) {
      out.stderr_[free[q]] = se(static_cast<Eigen::Index>(q));
      if (se(static_cast<Eigen::Index>(q)) > worst_se) {
        worst_se = se(static_cast<Eigen::Index>(q));
        worst = free[q];
      }
    }
    if (worst == 4) break;
    held[worst] = true;
    f[worst] = 1.0;
    out.stderr_[worst] = NAN;
    out.held_reason[worst] =
        std::isfinite(worst_se)
            ? fmt::format("not identified by these curves: standard error {:.3g}", worst_se)
            : std::string("not identified by these curves: no curvature of the fit along it");
  }
  out.value = f;
  const Scalings<double> s{f[0], f[1], f[2], f[3]};
  out.curves = evaluate_curves(reference, rig, s);
  out.rms_pct_peak = overall_rms_pct(out.curves);
  out.unscaled_rms_pct_peak = overall_rms_pct(evaluate_curves(reference, rig));
  return out;
}

}  // namespace brakefit::tyre
