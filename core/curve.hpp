#pragma once
// A measured or synthetic brake-force/slip curve and its resampling onto the fixed slip grid that
// the SOM and MLP work on.
#include <stdexcept>
#include <string>
#include <vector>

#include "core/magic_formula.hpp"

namespace brakefit {

/// Bad input (file content, configuration, model file): the message names file and line or key.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Curve {
  std::vector<double> slip_ratio;
  std::vector<double> force_n;
  std::size_t size() const { return slip_ratio.size(); }
  /// Largest |force| in the data (the "measured peak").
  double peak_abs_force_n() const;
  double max_slip_ratio() const;
};

/// Samples the formula at the given slips.
Curve sample_curve(const MfParams& p, const std::vector<double>& slip_ratio);
/// n slips evenly spaced in (0, slip_max] (first point at slip_max/n).
std::vector<double> even_slips(std::size_t n, double slip_max);

/// The fixed slip grid (ratios, increasing): dense where the peak lives.
/// 0.01..0.30 step 0.01, 0.325..0.50 step 0.025, 0.55..1.00 step 0.05 (48 points).
std::vector<double> default_slip_grid();

/// A curve on the grid; mask[k] = false where the data does not reach grid point k.
struct GridCurve {
  std::vector<double> values;
  std::vector<bool> mask;
  std::size_t valid_count() const;
  double last_valid_slip(const std::vector<double>& grid) const;
};

/// Resamples onto the grid: points outside the data's slip range are masked; inside, each grid
/// value is a local linear regression over the data in the grid cell (smooths noise), falling back
/// to linear interpolation where the cell holds fewer than three points.
GridCurve resample_to_grid(const Curve& c, const std::vector<double>& grid);

}  // namespace brakefit
