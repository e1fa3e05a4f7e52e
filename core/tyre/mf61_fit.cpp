#include "core/tyre/mf61_fit.hpp"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/curve_csv.hpp"
#include "core/fit/mf_fit.hpp"
#include "core/tyre/covariance.hpp"

namespace brakefit::tyre {

namespace {

constexpr std::size_t idx(Coef c) {
  return static_cast<std::size_t>(c);
}

/// One measured point: its residual is (model - measured) / weight.
struct PointResidual {
  const Mf61Reference* ref;
  OperatingPoint op;
  double slip_ratio, force_n, weight;
  template <typename T>
  bool operator()(const T* c, T* r) const {
    r[0] = (-mf61_fx<T>(c, *ref, op, -slip_ratio) - force_n) / weight;
    return true;
  }
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::size_t distinct(std::vector<double> v, double share) {
  std::sort(v.begin(), v.end());
  std::size_t n = 0;
  double start = -1;
  for (double x : v)
    if (n == 0 || (x - start) > share * std::abs(start)) {
      ++n;
      start = x;
    }
  return n;
}

/// Least-squares line y = a + b x (b = 0 with one distinct x).
std::pair<double, double> line_fit(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  const double mx = std::accumulate(x.begin(), x.end(), 0.0) / n;
  const double my = std::accumulate(y.begin(), y.end(), 0.0) / n;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  const double b = sxx > 1e-12 ? sxy / sxx : 0.0;
  return {my - b * mx, b};
}

double clamp_to_range(std::size_t i, double v) {
  const CoefRange& r = coef_range(i);
  const double margin = 1e-6 * (r.hi - r.lo);
  return std::clamp(v, r.lo + margin, r.hi - margin);
}

/// Seeds the free load-law coefficients from the per-curve Pacejka-96 fits: PDX1/PDX2 from D / Fz
/// against dfz, PKX1/PKX2 from B C D / Fz against dfz, PCX1 and PEX1 from the medians.
CoefVector seed(const std::vector<MfParams>& pac, const std::vector<TyreCurve>& curves,
                const Mf61Reference& ref) {
  CoefVector c{};
  for (std::size_t i = 0; i < kCoefCount; ++i) c[i] = coef_range(i).held_default;
  std::vector<double> dfz, mu, kx, cs, es;
  for (std::size_t i = 0; i < curves.size(); ++i) {
    const double fz = curves[i].op.fz_n;
    dfz.push_back((fz - ref.fnomin_n) / ref.fnomin_n);
    mu.push_back(pac[i].D / fz);
    kx.push_back(pac[i].B * pac[i].C * pac[i].D / fz);
    cs.push_back(pac[i].C);
    es.push_back(pac[i].E);
  }
  const auto [pdx1, pdx2] = line_fit(dfz, mu);
  const auto [pkx1, pkx2] = line_fit(dfz, kx);
  c[idx(Coef::PDX1)] = clamp_to_range(idx(Coef::PDX1), pdx1);
  c[idx(Coef::PDX2)] = clamp_to_range(idx(Coef::PDX2), pdx2 / std::max(pdx1, 0.2));
  c[idx(Coef::PKX1)] = clamp_to_range(idx(Coef::PKX1), pkx1);
  c[idx(Coef::PKX2)] = clamp_to_range(idx(Coef::PKX2), pkx2);
  c[idx(Coef::PCX1)] = clamp_to_range(idx(Coef::PCX1), median(cs));
  c[idx(Coef::PEX1)] = clamp_to_range(idx(Coef::PEX1), median(es));
  return c;
}

class JointProblem {
 public:
  JointProblem(const std::vector<TyreCurve>& curves, const Mf61Reference& ref) : ref_(ref) {
    // points_ point at ref_: the problem is neither copied nor moved.
    for (const auto& tc : curves) {
      const double peak = std::max(tc.curve.peak_abs_force_n(), 1e-9);
      const Curve thin = thin_curve(tc.curve, kMaxFitPoints);
      // Each curve counts equally whatever its sampling rate: a residual is a share of the
      // curve's peak, scaled by 1/sqrt(points).
      const double w = peak * std::sqrt(static_cast<double>(thin.size()));
      for (std::size_t k = 0; k < thin.size(); ++k)
        points_.push_back({&ref_, tc.op, thin.slip_ratio[k], thin.force_n[k], w});
    }
  }

  /// Solves with the coefficients in `held` fixed at their current values in c.
  ceres::Solver::Summary solve(CoefVector& c, const std::vector<bool>& held, double huber_scale,
                               int max_iterations) const {
    ceres::Problem::Options po;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    ceres::HuberLoss huber(huber_scale > 0 ? huber_scale : 1.0);
    for (const auto& p : points_)
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<PointResidual, 1, kCoefCount>(new PointResidual(p)),
          huber_scale > 0 ? &huber : nullptr, c.data());
    std::vector<int> fixed;
    for (std::size_t i = 0; i < kCoefCount; ++i)
      if (held[i]) fixed.push_back(static_cast<int>(i));
    if (!fixed.empty()) problem.SetManifold(c.data(), new ceres::SubsetManifold(kCoefCount, fixed));
    for (std::size_t i = 0; i < kCoefCount; ++i) {
      if (held[i]) continue;
      problem.SetParameterLowerBound(c.data(), static_cast<int>(i), coef_range(i).lo);
      problem.SetParameterUpperBound(c.data(), static_cast<int>(i), coef_range(i).hi);
    }
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = max_iterations;
    so.function_tolerance = 1e-12;
    so.parameter_tolerance = 1e-12;
    so.num_threads = 1;
    so.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    return summary;
  }

  /// Residuals (model - measured, in units of the weight) at c.
  Eigen::VectorXd residuals(const CoefVector& c) const {
    Eigen::VectorXd r(static_cast<Eigen::Index>(points_.size()));
    for (std::size_t k = 0; k < points_.size(); ++k)
      points_[k](c.data(), &r[static_cast<Eigen::Index>(k)]);
    return r;
  }

  /// Standard errors of the free coefficients (Gauss-Newton covariance, scaled by the residual
  /// variance); infinity where the Jacobian has no rank for a coefficient.
  CoefVector standard_errors(const CoefVector& c, const std::vector<bool>& held) const {
    std::vector<std::size_t> free;
    for (std::size_t i = 0; i < kCoefCount; ++i)
      if (!held[i]) free.push_back(i);
    CoefVector se;
    se.fill(NAN);
    if (free.empty()) return se;
    const auto m = static_cast<Eigen::Index>(points_.size());
    const auto p = static_cast<Eigen::Index>(free.size());
    Eigen::MatrixXd j(m, p);
    using Jet = ceres::Jet<double, kCoefCount>;
    std::array<Jet, kCoefCount> x;
    for (std::size_t i = 0; i < kCoefCount; ++i) x[i] = Jet(c[i], static_cast<int>(i));
    for (Eigen::Index k = 0; k < m; ++k) {
      Jet r;
      points_[static_cast<std::size_t>(k)](x.data(), &r);
      for (Eigen::Index q = 0; q < p; ++q)
        j(k, q) = r.v[static_cast<Eigen::Index>(free[static_cast<std::size_t>(q)])] *
                  (coef_range(free[static_cast<std::size_t>(q)]).hi -
                   coef_range(free[static_cast<std::size_t>(q)]).lo);
    }
    const Eigen::VectorXd scaled = scaled_standard_errors(j, residuals(c));
    for (Eigen::Index q = 0; q < p; ++q) {
      const std::size_t i = free[static_cast<std::size_t>(q)];
      se[i] = scaled(q) * (coef_range(i).hi - coef_range(i).lo);
    }
    return se;
  }

  JointProblem(const JointProblem&) = delete;
  JointProblem& operator=(const JointProblem&) = delete;

 private:
  Mf61Reference ref_;
  std::vector<PointResidual> points_;
};

void hold(std::vector<HeldCoef>& held, std::vector<bool>& is_held, CoefVector& c, Coef which,
          const std::string& reason) {
  const std::size_t i = idx(which);
  if (is_held[i]) return;
  is_held[i] = true;
  c[i] = coef_range(i).held_default;
  held.push_back({i, c[i], reason});
}

}  // namespace

Curve thin_curve(const Curve& c, std::size_t max_points) {
  if (c.size() <= max_points) return c;
  std::vector<std::size_t> order(c.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return c.slip_ratio[a] < c.slip_ratio[b]; });
  const std::size_t groups = max_points;
  Curve out;
  for (std::size_t g = 0; g < groups; ++g) {
    const std::size_t from = g * c.size() / groups, to = (g + 1) * c.size() / groups;
    double s = 0, f = 0;
    for (std::size_t k = from; k < to; ++k) {
      s += c.slip_ratio[order[k]];
      f += c.force_n[order[k]];
    }
    const auto n = static_cast<double>(to - from);
    out.slip_ratio.push_back(s / n);
    out.force_n.push_back(f / n);
  }
  return out;
}

std::vector<MfParams> pac96_fits(const std::vector<TyreCurve>& curves) {
  std::vector<MfParams> pac;
  for (const auto& tc : curves)
    pac.push_back(tc.pac96 ? *tc.pac96
                           : fit::fit_mf(tc.curve, fit::classic_start(tc.curve)).params);
  return pac;
}

bool any_curve_past_peak(const std::vector<TyreCurve>& curves, const std::vector<MfParams>& pac) {
  for (std::size_t i = 0; i < curves.size(); ++i) {
    const double max_slip = curves[i].curve.max_slip_ratio();
    const MfPeak peak = mf_peak(pac[i], max_slip);
    if (peak.interior && max_slip > 1.2 * peak.slip_ratio) return true;
  }
  return false;
}

std::vector<CurveFit> evaluate_curves(const Mf61Tyre& t, const std::vector<TyreCurve>& curves,
                                      const Scalings<double>& s) {
  std::vector<CurveFit> out;
  for (const auto& tc : curves) {
    CurveFit cf{
        tc.source, tc.op, tc.curve.size(), tc.curve.max_slip_ratio(), tc.curve.peak_abs_force_n(),
        0.0};
    double ss = 0;
    for (std::size_t k = 0; k < tc.curve.size(); ++k) {
      const double f = -mf61_fx<double>(t.coef.data(), t.ref, tc.op, -tc.curve.slip_ratio[k], s);
      ss += (f - tc.curve.force_n[k]) * (f - tc.curve.force_n[k]);
    }
    cf.rms_pct_peak =
        100.0 * std::sqrt(ss / static_cast<double>(cf.points)) / std::max(cf.peak_force_n, 1e-9);
    out.push_back(cf);
  }
  return out;
}

double overall_rms_pct(const std::vector<CurveFit>& curves) {
  double sum_sq = 0;
  for (const auto& c : curves) sum_sq += c.rms_pct_peak * c.rms_pct_peak;
  return curves.empty() ? 0.0 : std::sqrt(sum_sq / static_cast<double>(curves.size()));
}

std::string Mf61FitResult::held_reason(std::size_t i) const {
  for (const auto& h : held)
    if (h.index == i) return h.reason;
  return {};
}

bool Mf61FitResult::held_at(std::size_t i) const {
  return std::any_of(held.begin(), held.end(), [i](const HeldCoef& h) { return h.index == i; });
}

Mf61FitResult fit_mf61(const std::vector<TyreCurve>& curves, const Mf61FitOptions& o) {
  if (curves.empty()) throw InputError("tyre fit: no curves");
  std::vector<double> loads, pressures, speeds;
  for (const auto& tc : curves) {
    if (tc.curve.size() < kMinCurvePoints)
      throw InputError(fmt::format("{}: {} points, a curve needs {}", tc.source, tc.curve.size(),
                                   kMinCurvePoints));
    if (!(tc.op.fz_n > 0) || !(tc.op.pressure_pa > 0) || !(tc.op.speed_mps > 0))
      throw InputError(
          fmt::format("{}: wheel load, tyre pressure and speed must be positive", tc.source));
    loads.push_back(tc.op.fz_n);
    pressures.push_back(tc.op.pressure_pa);
    speeds.push_back(tc.op.speed_mps);
  }
  Mf61FitResult res;
  Mf61Reference& ref = res.tyre.ref;
  ref.fnomin_n = std::isfinite(o.fnomin_n) ? o.fnomin_n : median(loads);
  ref.nompres_pa = std::isfinite(o.nompres_pa) ? o.nompres_pa : median(pressures);
  ref.longvl_mps = o.longvl_mps;
  res.loads = distinct(loads, o.same_condition_share);
  res.pressures = distinct(pressures, o.same_condition_share);
  res.speeds = distinct(speeds, o.same_condition_share);

  const std::vector<MfParams> pac = pac96_fits(curves);
  const bool any_past_peak = any_curve_past_peak(curves, pac);

  CoefVector& c = res.tyre.coef;
  c = seed(pac, curves, ref);
  std::vector<bool> is_held(kCoefCount, false);
  auto& held = res.held;
  hold(held, is_held, c, Coef::PEX4,
       "braking slip only: PEX4 splits E between driving and braking");
  if (res.loads < 2) {
    const std::string why =
        fmt::format("one wheel load ({:.0f} N): a load law needs two", loads[0]);
    for (Coef k :
         {Coef::PDX2, Coef::PEX2, Coef::PEX3, Coef::PKX2, Coef::PKX3, Coef::PHX2, Coef::PVX2})
      hold(held, is_held, c, k, why);
  } else if (res.loads == 2) {
    for (Coef k : {Coef::PEX3, Coef::PKX3})
      hold(held, is_held, c, k,
           "two wheel loads: a quadratic or exponential load term needs three");
  }
  if (res.pressures < 2) {
    for (Coef k : {Coef::PPX1, Coef::PPX2, Coef::PPX3, Coef::PPX4})
      hold(held, is_held, c, k, "one inflation pressure: a pressure law needs two");
  } else if (res.pressures == 2) {
    for (Coef k : {Coef::PPX2, Coef::PPX4})
      hold(held, is_held, c, k, "two inflation pressures: a quadratic pressure term needs three");
  }
  if (res.speeds < 2)
    hold(held, is_held, c, Coef::LMUV,
         "one speed: the slip-speed decay cannot be told from the curve's shape");
  if (!any_past_peak)
    for (Coef k : {Coef::PCX1, Coef::PEX1, Coef::PEX2, Coef::PEX3})
      hold(held, is_held, c, k,
           "no curve goes past its force peak: the shape beyond it is unmeasured");

  const JointProblem problem(curves, ref);
  // A plain least-squares pass finds the residual scale; later passes use a Huber loss at three
  // times it, so a few wild points (a lost edge, a spike) cannot pull the tyre.
  ceres::Solver::Summary s = problem.solve(c, is_held, 0.0, o.max_iterations);
  ++res.solves;
  res.iterations += static_cast<int>(s.iterations.size());
  const double rms0 =
      std::sqrt(problem.residuals(c).squaredNorm() / static_cast<double>(curves.size()));
  const double huber = 3.0 * std::max(rms0, 1e-6);
  for (;;) {
    s = problem.solve(c, is_held, huber, o.max_iterations);
    ++res.solves;
    res.iterations += static_cast<int>(s.iterations.size());
    res.stderr_ = problem.standard_errors(c, is_held);
    std::size_t worst = kCoefCount;
    double worst_share = o.identifiable_share;
    for (std::size_t i = 0; i < kCoefCount; ++i) {
      if (is_held[i]) continue;
      const double share = res.stderr_[i] / (coef_range(i).hi - coef_range(i).lo);
      if (share > worst_share) {
        worst_share = share;
        worst = i;
      }
    }
    if (worst == kCoefCount) break;
    const std::string why =
        std::isfinite(res.stderr_[worst])
            ? fmt::format(
                  "not identified by these curves: standard error {:.3g} is {:.0f} % of its "
                  "range [{:g}, {:g}]",
                  res.stderr_[worst], 100 * worst_share, coef_range(worst).lo, coef_range(worst).hi)
            : std::string("not identified by these curves: no curvature of the fit along it");
    hold(held, is_held, c, static_cast<Coef>(worst), why);
  }
  res.converged = s.termination_type == ceres::CONVERGENCE;
  for (std::size_t i = 0; i < kCoefCount; ++i) {
    if (is_held[i]) continue;
    const CoefRange& r = coef_range(i);
    if (std::min(c[i] - r.lo, r.hi - c[i]) < 1e-4 * (r.hi - r.lo))
      res.at_bound.emplace_back(coef_name(i));
  }

  res.curves = evaluate_curves(res.tyre, curves);
  res.rms_pct_peak = overall_rms_pct(res.curves);
  return res;
}

}  // namespace brakefit::tyre
