#include "core/fit/lm.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>

namespace brakefit::fit {

const char* to_string(LmStatus s) {
  switch (s) {
    case LmStatus::Gradient:
      return "gradient";
    case LmStatus::Step:
      return "step";
    case LmStatus::Cost:
      return "cost";
    case LmStatus::MaxIterations:
      return "max_iterations";
    case LmStatus::Stuck:
      return "stuck";
  }
  return "?";
}

namespace {

Eigen::VectorXd clamp(const Eigen::VectorXd& x, const Eigen::VectorXd& lo,
                      const Eigen::VectorXd& hi) {
  return x.cwiseMax(lo).cwiseMin(hi);
}

std::vector<bool> free_set(const Eigen::VectorXd& x, const Eigen::VectorXd& g,
                           const Eigen::VectorXd& lo, const Eigen::VectorXd& hi) {
  std::vector<bool> free(static_cast<std::size_t>(x.size()));
  for (Eigen::Index i = 0; i < x.size(); ++i)
    free[static_cast<std::size_t>(i)] =
        !((x(i) <= lo(i) && g(i) > 0) || (x(i) >= hi(i) && g(i) < 0));
  return free;
}

}  // namespace

Eigen::VectorXd standard_errors_holding(const LmResult& r, const std::vector<bool>& held) {
  const Eigen::Index n = r.x.size();
  Eigen::VectorXd out = Eigen::VectorXd::Constant(n, NAN);
  std::vector<Eigen::Index> idx;
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (!(k < r.at_bound.size() && r.at_bound[k]) && !(k < held.size() && held[k]))
      idx.push_back(i);
  }
  const auto p = static_cast<Eigen::Index>(idx.size());
  if (p == 0 || r.residuals <= p || r.jtj.rows() != n) return out;
  Eigen::MatrixXd af(p, p);
  for (Eigen::Index u = 0; u < p; ++u)
    for (Eigen::Index v = 0; v < p; ++v)
      af(u, v) = r.jtj(idx[static_cast<std::size_t>(u)], idx[static_cast<std::size_t>(v)]);
  Eigen::FullPivLU<Eigen::MatrixXd> lu(af);
  if (!lu.isInvertible()) return out;
  const Eigen::MatrixXd cov = lu.inverse() * (r.ssr / static_cast<double>(r.residuals - p));
  for (Eigen::Index u = 0; u < p; ++u)
    if (cov(u, u) >= 0) out(idx[static_cast<std::size_t>(u)]) = std::sqrt(cov(u, u));
  return out;
}

LmResult minimize(const LeastSquaresProblem& problem, const Eigen::VectorXd& x0,
                  const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                  const LmOptions& opt) {
  const Eigen::Index n = x0.size();
  const Eigen::Index m = problem.residual_count();
  LmResult res;
  Eigen::VectorXd x = clamp(x0, lower, upper);
  Eigen::VectorXd r(m), r_new(m);
  Eigen::MatrixXd j(m, n);
  problem.evaluate(x, r, &j);
  double f = r.squaredNorm();
  Eigen::MatrixXd a = j.transpose() * j;
  Eigen::VectorXd g = j.transpose() * r;
  Eigen::VectorXd diag = a.diagonal().cwiseMax(1e-300);
  double lambda = 1e-3, nu = 2.0;
  std::vector<bool> free = free_set(x, g, lower, upper);
  int it = 0;
  for (; it < opt.max_iterations; ++it) {
    free = free_set(x, g, lower, upper);
    // Gradient test: cosine between r and each free Jacobian column.
    double gmax = 0.0;
    for (Eigen::Index i = 0; i < n; ++i)
      if (free[static_cast<std::size_t>(i)] && a(i, i) > 0)
        gmax = std::max(gmax, std::abs(g(i)) / std::sqrt(a(i, i) * std::max(f, 1e-300)));
    if (gmax <= opt.gtol || f == 0.0) {
      res.status = LmStatus::Gradient;
      res.converged = true;
      break;
    }
    bool accepted = false;
    while (!accepted) {
      Eigen::MatrixXd lhs = a;
      Eigen::VectorXd rhs = -g;
      for (Eigen::Index i = 0; i < n; ++i) {
        if (free[static_cast<std::size_t>(i)]) {
          lhs(i, i) += lambda * diag(i);
        } else {  // hold at its bound
          lhs.row(i).setZero();
          lhs.col(i).setZero();
          lhs(i, i) = 1.0;
          rhs(i) = 0.0;
        }
      }
      const Eigen::VectorXd h = lhs.ldlt().solve(rhs);
      const Eigen::VectorXd x_new = clamp(x + h, lower, upper);
      const Eigen::VectorXd step = x_new - x;
      if (!step.allFinite()) {
        res.status = LmStatus::Stuck;
        break;
      }
      if (step.norm() <= opt.xtol * (x.norm() + opt.xtol)) {
        res.status = LmStatus::Step;
        res.converged = true;
        break;
      }
      problem.evaluate(x_new, r_new, nullptr);
      const double f_new = r_new.squaredNorm();
      const double predicted = -(2.0 * g.dot(step) + step.dot(a * step));
      const double rho = predicted > 0 ? (f - f_new) / predicted : -1.0;
      if (std::isfinite(f_new) && f_new < f && rho > 1e-4) {
        const double reduction = f - f_new;
        x = x_new;
        r = r_new;
        f = f_new;
        problem.evaluate(x, r, &j);
        a.noalias() = j.transpose() * j;
        g.noalias() = j.transpose() * r;
        diag = diag.cwiseMax(a.diagonal());
        lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
        nu = 2.0;
        accepted = true;
        if (reduction <= opt.ftol * (f + reduction)) {
          res.status = LmStatus::Cost;
          res.converged = true;
        }
      } else {
        lambda *= nu;
        nu *= 2.0;
        if (lambda > 1e20) {
          res.status = LmStatus::Stuck;
          break;
        }
      }
    }
    if (res.converged || res.status == LmStatus::Stuck) {
      ++it;
      break;
    }
  }
  if (it >= opt.max_iterations && !res.converged && res.status != LmStatus::Stuck)
    res.status = LmStatus::MaxIterations;
  res.x = x;
  res.ssr = f;
  res.iterations = it;
  res.jtj = a;
  res.at_bound.resize(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i)
    res.at_bound[static_cast<std::size_t>(i)] = x(i) <= lower(i) || x(i) >= upper(i);
  res.residuals = m;
  res.standard_errors =
      standard_errors_holding(res, std::vector<bool>(static_cast<std::size_t>(n)));
  return res;
}

}  // namespace brakefit::fit
