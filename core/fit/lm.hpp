#pragma once
// Bounded Levenberg-Marquardt for small nonlinear least-squares problems (Eigen). The problem is a
// functor giving residuals and their Jacobian (as in Eigen's unsupported LevenbergMarquardt);
// bounds are handled by projection with an active set (a parameter at a bound whose gradient
// points outward is held fixed for the step). Marquardt scaling (MINPACK style) keeps it
// invariant to parameter units.
#include <Eigen/Core>
#include <vector>

namespace brakefit::fit {

class LeastSquaresProblem {
 public:
  virtual ~LeastSquaresProblem() = default;
  virtual Eigen::Index residual_count() const = 0;
  /// r = residuals at x; if j is not null, j = dr/dx (residual_count x x.size()).
  virtual void evaluate(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd* j) const = 0;
};

struct LmOptions {
  int max_iterations = 200;
  double gtol = 1e-10;  ///< max cosine between residual and a Jacobian column
  double xtol = 1e-10;  ///< relative step
  double ftol = 1e-15;  ///< relative reduction of the cost
};

enum class LmStatus { Gradient, Step, Cost, MaxIterations, Stuck };
const char* to_string(LmStatus s);

struct LmResult {
  Eigen::VectorXd x;
  double ssr = 0.0;  ///< sum of squared residuals
  int iterations = 0;
  LmStatus status = LmStatus::MaxIterations;
  bool converged = false;
  Eigen::MatrixXd jtj;         ///< J^T J at the solution
  std::vector<bool> at_bound;  ///< parameters held at a bound at the end
  Eigen::Index residuals = 0;  ///< the problem's residual count
  /// Standard errors sqrt(diag(s^2 (J^T J)^-1)) over the free parameters, s^2 = ssr/(n - p);
  /// NaN for parameters at a bound or when J^T J is singular.
  Eigen::VectorXd standard_errors;
};

/// Standard errors as LmResult::standard_errors gives them but with the parameters marked in
/// `held` also held (as if known), besides those at a bound. A parameter that shares its Jacobian
/// column with a bounded nuisance term has no error of its own while both are free (the sum is
/// determined, not the share): held, the nuisance's bound stands in for its uncertainty.
Eigen::VectorXd standard_errors_holding(const LmResult& r, const std::vector<bool>& held);

LmResult minimize(const LeastSquaresProblem& problem, const Eigen::VectorXd& x0,
                  const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                  const LmOptions& options = {});

}  // namespace brakefit::fit
