#include "core/som/lattice.hpp"

#include <cmath>

namespace brakefit::som {

HexLattice::HexLattice(std::size_t rows, std::size_t cols) : rows_(rows), cols_(cols) {
  const auto n = static_cast<Eigen::Index>(size());
  dist_.resize(n, n);
  neighbours_.assign(size(), {});
  for (std::size_t a = 0; a < size(); ++a) {
    for (std::size_t b = 0; b < size(); ++b) {
      const double d = std::hypot(x(a) - x(b), y(a) - y(b));
      dist_(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) = d;
      if (a != b && std::abs(d - 1.0) < 1e-9) neighbours_[a].push_back(b);
    }
  }
}

double HexLattice::x(std::size_t unit) const {
  const std::size_t r = unit / cols_, c = unit % cols_;
  return static_cast<double>(c) + ((r % 2) ? 0.5 : 0.0);
}

double HexLattice::y(std::size_t unit) const {
  const std::size_t row = unit / cols_;
  return static_cast<double>(row) * std::sqrt(0.75);
}

}  // namespace brakefit::som
