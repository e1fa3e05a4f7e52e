#pragma once
// Standard errors of least-squares parameters from the Jacobian at the solution (Gauss-Newton
// covariance scaled by the residual variance), robust to a rank-deficient Jacobian: a parameter
// with a component along a direction of no curvature gets infinity, not a number from noise.
#include <Eigen/Dense>

namespace brakefit::tyre {

/// j: residuals x parameters, each column already multiplied by its parameter's scale (so the
/// singular values compare like with like); r: the residuals. Returns each parameter's standard
/// error in units of its scale (multiply by the scale for the parameter's own unit).
Eigen::VectorXd scaled_standard_errors(const Eigen::MatrixXd& j, const Eigen::VectorXd& r);

}  // namespace brakefit::tyre
