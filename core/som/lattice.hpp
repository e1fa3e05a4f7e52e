#pragma once
// Hexagonal sheet lattice as in SOM Toolbox 2: unit (row r, col c) sits at x = c + 0.5*(r odd),
// y = r*sqrt(0.75), so all six neighbours of an interior unit are at distance exactly 1.
// Units are numbered row-major: index = r*cols + c.
#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace brakefit::som {

class HexLattice {
 public:
  HexLattice() = default;
  HexLattice(std::size_t rows, std::size_t cols);
  std::size_t rows() const { return rows_; }
  std::size_t cols() const { return cols_; }
  std::size_t size() const { return rows_ * cols_; }
  double x(std::size_t unit) const;
  double y(std::size_t unit) const;
  double distance(std::size_t a, std::size_t b) const {
    return dist_(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
  }
  /// Units at lattice distance 1 (the 1-neighbourhood).
  const std::vector<std::size_t>& neighbours(std::size_t unit) const { return neighbours_[unit]; }
  bool adjacent(std::size_t a, std::size_t b) const {
    return std::abs(distance(a, b) - 1.0) < 1e-9;
  }
  const Eigen::MatrixXd& distances() const { return dist_; }

 private:
  std::size_t rows_ = 0, cols_ = 0;
  Eigen::MatrixXd dist_;
  std::vector<std::vector<std::size_t>> neighbours_;
};

}  // namespace brakefit::som
