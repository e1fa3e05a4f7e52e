#include "core/curve.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace brakefit {

double Curve::peak_abs_force_n() const {
  double m = 0.0;
  for (double f : force_n) m = std::max(m, std::abs(f));
  return m;
}

double Curve::max_slip_ratio() const {
  return slip_ratio.empty() ? 0.0 : *std::max_element(slip_ratio.begin(), slip_ratio.end());
}

Curve sample_curve(const MfParams& p, const std::vector<double>& slip_ratio) {
  Curve c;
  c.slip_ratio = slip_ratio;
  c.force_n.reserve(slip_ratio.size());
  for (double s : slip_ratio) c.force_n.push_back(mf_force_n(p, s));
  return c;
}

std::vector<double> even_slips(std::size_t n, double slip_max) {
  std::vector<double> s(n);
  for (std::size_t i = 0; i < n; ++i)
    s[i] = slip_max * static_cast<double>(i + 1) / static_cast<double>(n);
  return s;
}

std::vector<double> default_slip_grid() {
  std::vector<double> g;
  for (int i = 1; i <= 30; ++i) g.push_back(0.01 * i);
  for (int i = 1; i <= 8; ++i) g.push_back(0.30 + 0.025 * i);
  for (int i = 1; i <= 10; ++i) g.push_back(0.50 + 0.05 * i);
  return g;
}

std::size_t GridCurve::valid_count() const {
  return static_cast<std::size_t>(std::count(mask.begin(), mask.end(), true));
}

double GridCurve::last_valid_slip(const std::vector<double>& grid) const {
  double s = 0.0;
  for (std::size_t k = 0; k < mask.size(); ++k)
    if (mask[k]) s = grid[k];
  return s;
}

GridCurve resample_to_grid(const Curve& c, const std::vector<double>& grid) {
  std::vector<std::size_t> order(c.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return c.slip_ratio[a] < c.slip_ratio[b]; });
  std::vector<double> xs(c.size()), ys(c.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    xs[i] = c.slip_ratio[order[i]];
    ys[i] = c.force_n[order[i]];
  }
  GridCurve out;
  out.values.assign(grid.size(), 0.0);
  out.mask.assign(grid.size(), false);
  if (xs.empty()) return out;
  // Tolerance: a grid point within 1e-9 of the data range still counts as covered.
  const double lo = xs.front() - 1e-9, hi = xs.back() + 1e-9;
  for (std::size_t k = 0; k < grid.size(); ++k) {
    const double g = grid[k];
    if (g < lo || g > hi) continue;
    const double left = k == 0 ? g - (grid[1] - g) / 2 : (grid[k - 1] + g) / 2;
    const double right = k + 1 == grid.size() ? g + (g - grid[k - 1]) / 2 : (g + grid[k + 1]) / 2;
    const auto b = std::lower_bound(xs.begin(), xs.end(), left) - xs.begin();
    const auto e = std::lower_bound(xs.begin(), xs.end(), right) - xs.begin();
    bool done = false;
    if (e - b >= 3) {  // local linear regression centred on g
      double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
      for (auto i = b; i < e; ++i) {
        const double dx = xs[i] - g;
        sw += 1;
        sx += dx;
        sy += ys[i];
        sxx += dx * dx;
        sxy += dx * ys[i];
      }
      const double det = sw * sxx - sx * sx;
      if (det > 1e-300 * sw * sw) {
        out.values[k] = (sxx * sy - sx * sxy) / det;
        done = true;
      }
    }
    if (!done) {  // linear interpolation
      const auto j = std::upper_bound(xs.begin(), xs.end(), g) - xs.begin();
      if (j == 0) {
        out.values[k] = ys.front();
      } else if (j == static_cast<long>(xs.size())) {
        out.values[k] = ys.back();
      } else {
        const double x0 = xs[j - 1], x1 = xs[j];
        const double t = x1 > x0 ? (g - x0) / (x1 - x0) : 0.5;
        out.values[k] = ys[j - 1] + t * (ys[j] - ys[j - 1]);
      }
    }
    out.mask[k] = true;
  }
  return out;
}

}  // namespace brakefit
