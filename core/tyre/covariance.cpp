#include "core/tyre/covariance.hpp"

#include <algorithm>
#include <cmath>

namespace brakefit::tyre {

Eigen::VectorXd scaled_standard_errors(const Eigen::MatrixXd& j, const Eigen::VectorXd& r) {
  const Eigen::Index m = j.rows(), p = j.cols();
  Eigen::VectorXd se(p);
  if (p == 0) return se;
  const double dof = std::max<double>(1.0, static_cast<double>(m - p));
  const double s2 = r.squaredNorm() / dof;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(j, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const Eigen::MatrixXd& v = svd.matrixV();
  const double tol = 1e-9 * std::max(sv(0), 1e-300);
  for (Eigen::Index q = 0; q < p; ++q) {
    double var = 0;
    bool unbounded = false;
    for (Eigen::Index k = 0; k < sv.size(); ++k) {
      if (sv(k) <= tol) {
        unbounded = unbounded || std::abs(v(q, k)) > 1e-6;
        continue;
      }
      var += v(q, k) * v(q, k) / (sv(k) * sv(k));
    }
    se(q) = unbounded ? INFINITY : std::sqrt(s2 * var);
  }
  return se;
}

}  // namespace brakefit::tyre
