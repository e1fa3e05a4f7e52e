#include "core/fit/mf_fit.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace brakefit::fit {

namespace {

class MfProblem final : public LeastSquaresProblem {
 public:
  MfProblem(const Curve& c, bool shifts) : c_(c), n_params_(shifts ? 6 : 4) {}
  Eigen::Index residual_count() const override { return static_cast<Eigen::Index>(c_.size()); }
  void evaluate(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd* j) const override {
    const MfParams p =
        from_array(std::span<const double>(x.data(), static_cast<std::size_t>(x.size())));
    MfGradient grad;
    for (std::size_t i = 0; i < c_.size(); ++i) {
      const auto row = static_cast<Eigen::Index>(i);
      if (j) {
        const double f = mf_force_and_gradient(p, c_.slip_ratio[i], grad);
        r(row) = f - c_.force_n[i];
        for (Eigen::Index k = 0; k < n_params_; ++k)
          (*j)(row, k) = grad[static_cast<std::size_t>(k)];
      } else {
        r(row) = mf_force_n(p, c_.slip_ratio[i]) - c_.force_n[i];
      }
    }
  }

 private:
  const Curve& c_;
  Eigen::Index n_params_;
};

}  // namespace

MfParams classic_start(const Curve& c) {
  MfParams p;
  p.B = 10.0;
  p.C = 1.5;
  p.D = c.force_n.empty() ? 1.0 : *std::max_element(c.force_n.begin(), c.force_n.end());
  p.E = 0.0;
  return p;
}

bool peak_reached(const MfParams& p, double slip_max) {
  if (slip_max <= 0) return false;
  return mf_peak(p, slip_max).interior;
}

MfFitResult fit_mf(const Curve& c, const MfParams& start, const MfFitOptions& o) {
  const Eigen::Index np = o.fit_shifts ? 6 : 4;
  const double peak = std::max(c.peak_abs_force_n(), 1e-9);
  const auto& b = o.bounds;
  Eigen::VectorXd lo(np), hi(np), x0(np);
  lo.head(4) << b.B_lo, b.C_lo, b.D_lo_factor * peak, b.E_lo;
  hi.head(4) << b.B_hi, b.C_hi, b.D_hi_factor * peak, b.E_hi;
  x0.head(4) << start.B, start.C, start.D, start.E;
  if (o.fit_shifts) {
    lo.tail(2) << -b.SHx_abs, -b.SVx_abs_factor * peak;
    hi.tail(2) << b.SHx_abs, b.SVx_abs_factor * peak;
    x0.tail(2) << start.SHx, start.SVx;
  }
  MfProblem problem(c, o.fit_shifts);
  const LmResult lm = minimize(problem, x0, lo, hi, o.lm);
  MfFitResult out;
  out.params = from_array(std::span<const double>(lm.x.data(), static_cast<std::size_t>(np)));
  out.stderr_.fill(NAN);
  for (Eigen::Index k = 0; k < np; ++k)
    out.stderr_[static_cast<std::size_t>(k)] = lm.standard_errors(k);
  out.ssr = lm.ssr;
  out.rmse_n = c.size() ? std::sqrt(lm.ssr / static_cast<double>(c.size())) : NAN;
  out.iterations = lm.iterations;
  out.converged = lm.converged;
  out.status = lm.status;
  out.peak_reached = peak_reached(out.params, c.max_slip_ratio());
  static constexpr std::array<const char*, kMfParamCount> kNames{"B", "C", "D", "E", "SHx", "SVx"};
  for (Eigen::Index k = 0; k < np; ++k) {
    const auto i = static_cast<std::size_t>(k);
    const bool at = i < lm.at_bound.size() && lm.at_bound[i];
    if (at) out.at_bound.push_back(kNames[i]);
    if (std::isnan(out.stderr_[i]))
      out.stderr_null_reason[i] =
          at ? fmt::format("{} ended at its bound {:.6g}: the bound, not the data, set it",
                           kNames[i], lm.x(k))
             : "not identifiable from these data (the fit's curvature matrix is singular)";
  }
  return out;
}

}  // namespace brakefit::fit
