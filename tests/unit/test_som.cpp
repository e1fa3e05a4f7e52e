#include <gtest/gtest.h>

#include <cmath>

#include "core/rng.hpp"
#include "core/som/som.hpp"

using namespace brakefit;
using namespace brakefit::som;

TEST(HexLattice, InteriorUnitsHaveSixNeighboursAtExactlyOne) {
  const HexLattice lat(10, 10);
  for (std::size_t u = 0; u < lat.size(); ++u) {
    const std::size_t r = u / 10, c = u % 10;
    const bool interior = r > 0 && r < 9 && c > 0 && c < 9;
    if (interior) {
      EXPECT_EQ(lat.neighbours(u).size(), 6u) << "unit " << u;
    }
    for (std::size_t v : lat.neighbours(u)) EXPECT_NEAR(lat.distance(u, v), 1.0, 1e-12);
    for (std::size_t v = 0; v < lat.size(); ++v) {
      if (v != u) {
        EXPECT_GE(lat.distance(u, v), 1.0 - 1e-12);  // nothing closer than a neighbour
      }
    }
  }
  // Corners: (0,0) has 2 neighbours (right, and below-right in the shifted odd row); (1,9) has 3.
  EXPECT_EQ(lat.neighbours(0).size(), 2u);
  EXPECT_EQ(lat.neighbours(19).size(), 3u);
  // Two rows apart: sqrt(3); two columns apart: 2.
  EXPECT_NEAR(lat.distance(0, 20), std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(lat.distance(0, 2), 2.0, 1e-12);
  EXPECT_TRUE(lat.adjacent(0, 10));   // (0,0)-(1,0): odd row shifted by +0.5
  EXPECT_TRUE(lat.adjacent(1, 10));   // (0,1)-(1,0): 0.5 apart in x, sqrt(0.75) in y
  EXPECT_FALSE(lat.adjacent(2, 10));  // (0,2)-(1,0): sqrt(3) apart
}

TEST(Som, NeighbourhoodFunctionsAndRadiusSchedule) {
  EXPECT_NEAR(neighbourhood_weight(Neighbourhood::Gaussian, 2, 2), std::exp(-0.5), 1e-15);
  EXPECT_NEAR(neighbourhood_weight(Neighbourhood::CutGauss, 2, 2), std::exp(-0.5), 1e-15);
  EXPECT_EQ(neighbourhood_weight(Neighbourhood::CutGauss, 2.1, 2), 0.0);
  EXPECT_NEAR(neighbourhood_weight(Neighbourhood::Ep, 1, 2), 0.75, 1e-15);
  EXPECT_EQ(neighbourhood_weight(Neighbourhood::Ep, 2.5, 2), 0.0);
  EXPECT_EQ(neighbourhood_weight(Neighbourhood::Bubble, 2, 2), 1.0);
  EXPECT_EQ(neighbourhood_weight(Neighbourhood::Bubble, 2.01, 2), 0.0);
  EXPECT_DOUBLE_EQ(radius_at(3, 1, 1, 10), 3.0);
  EXPECT_DOUBLE_EQ(radius_at(3, 1, 10, 10), 1.0);
  EXPECT_DOUBLE_EQ(radius_at(3, 1, 4, 7), 2.0);
  const SomSettings d = with_default_radii(SomSettings{});
  EXPECT_DOUBLE_EQ(d.rough.radius_ini, 3.0);  // max(1, ceil(10/4))
  EXPECT_DOUBLE_EQ(d.rough.radius_fin, 1.0);  // max(1, 3/4)
  EXPECT_DOUBLE_EQ(d.fine.radius_fin, 1.0);
}

TEST(Som, QuantizationAndTopographicErrorHandComputed) {
  // Chain of three units at x = 0, 1, 2; 1-D codebook 0, 5, 1.
  Eigen::MatrixXd cb(3, 1);
  cb << 0, 5, 1;
  const Som s(HexLattice(1, 3), cb);
  Eigen::MatrixXd data(2, 1);
  data << 0.4, 4.0;
  // 0.4: BMU 0 (0.4), second 2 (0.6) -> units 0 and 2 are 2 apart: topographic error.
  // 4.0: BMU 1 (1.0), second 2 (3.0) -> adjacent.
  EXPECT_NEAR(s.quantization_error(data), (0.4 + 1.0) / 2, 1e-15);
  EXPECT_NEAR(s.topographic_error(data), 0.5, 1e-15);
}

TEST(Som, BatchRuleIsVoronoiMeanWithBubbleAndLeavesEmptyUnitsUnchanged) {
  Eigen::MatrixXd cb(3, 1);
  cb << 0, 10, 100;
  Som s(HexLattice(1, 3), cb);
  Eigen::MatrixXd data(4, 1);
  data << 1, 3, 9, 13;  // BMUs: 0, 0, 1, 1; unit 2 gets nothing
  const Eigen::VectorXd sq = data.rowwise().squaredNorm();
  s.batch_epoch(data, sq, Neighbourhood::Bubble, 0.5);  // radius below 1: only the BMU itself
  EXPECT_DOUBLE_EQ(s.codebook()(0, 0), 2.0);
  EXPECT_DOUBLE_EQ(s.codebook()(1, 0), 11.0);
  EXPECT_DOUBLE_EQ(s.codebook()(2, 0), 100.0);
  // Radius 1 bubble: unit 1 averages everything (its own and both neighbours' Voronoi sets).
  s.batch_epoch(data, sq, Neighbourhood::Bubble, 1.0);
  EXPECT_DOUBLE_EQ(s.codebook()(1, 0), 6.5);
}

namespace {

bool monotone(const Eigen::MatrixXd& cb) {
  bool inc = true, dec = true;
  for (Eigen::Index i = 1; i < cb.rows(); ++i) {
    inc = inc && cb(i, 0) > cb(i - 1, 0);
    dec = dec && cb(i, 0) < cb(i - 1, 0);
  }
  return inc || dec;
}

}  // namespace

TEST(Som, OneDimensionalChainBecomesOrdered) {
  Rng rng(3);
  Eigen::MatrixXd data(500, 1);
  for (Eigen::Index i = 0; i < data.rows(); ++i) data(i, 0) = rng.uniform();
  for (Algorithm alg : {Algorithm::Batch, Algorithm::Sequential}) {
    SomSettings s;
    s.rows = 1;
    s.cols = 10;
    s.algorithm = alg;
    s.rough.epochs = alg == Algorithm::Batch ? 50 : 10;
    s.fine.epochs = alg == Algorithm::Batch ? 50 : 10;
    s.seed = 11;
    Som som = Som::initialise(s, data);
    som.train(s, data);
    EXPECT_TRUE(monotone(som.codebook())) << to_string(alg) << "\n" << som.codebook().transpose();
    EXPECT_LT(som.quantization_error(data), 0.06);
  }
}

TEST(Som, TwoDimensionalMapPreservesTopology) {
  Rng rng(4);
  Eigen::MatrixXd data(1000, 2);
  for (Eigen::Index i = 0; i < data.rows(); ++i) data.row(i) << rng.uniform(), rng.uniform();
  for (Init init : {Init::Random, Init::Linear}) {
    SomSettings s;
    s.rows = 6;
    s.cols = 6;
    s.init = init;
    s.rough.epochs = 100;
    s.fine.epochs = 100;
    Som som = Som::initialise(s, data);
    som.train(s, data);
    EXPECT_LT(som.topographic_error(data), 0.1) << to_string(init);
    // Lattice neighbours are closer in data space than random pairs of units.
    const Eigen::VectorXd u = som.umatrix();
    double mean_pair = 0;
    int pairs = 0;
    for (std::size_t a = 0; a < som.units(); ++a)
      for (std::size_t b = a + 1; b < som.units(); ++b, ++pairs)
        mean_pair += (som.codebook().row(static_cast<Eigen::Index>(a)) -
                      som.codebook().row(static_cast<Eigen::Index>(b)))
                         .norm();
    mean_pair /= pairs;
    EXPECT_LT(u.mean(), 0.5 * mean_pair) << to_string(init);
  }
}

TEST(Som, LinearInitSpansThePrincipalDirection) {
  Eigen::MatrixXd data(100, 3);
  for (int i = 0; i < 100; ++i) data.row(i) << i, 2.0 * i, -i;  // a line through the origin
  SomSettings s;
  s.rows = 4;
  s.cols = 5;
  s.init = Init::Linear;
  const Som som = Som::initialise(s, data);
  const Eigen::Vector3d dir = Eigen::Vector3d(1, 2, -1).normalized();
  const Eigen::RowVector3d mean = data.colwise().mean();
  for (Eigen::Index i = 0; i < som.codebook().rows(); ++i) {
    const Eigen::Vector3d v = (som.codebook().row(i) - mean).transpose();
    EXPECT_NEAR((v - v.dot(dir) * dir).norm(), 0.0, 1e-6);  // on the line
  }
  EXPECT_GT((som.codebook().row(0) - som.codebook().row(4)).norm(), 50.0);  // spread along it
}

TEST(Som, MaskedScaleInvariantMatchRecoversUnitAndScale) {
  Eigen::MatrixXd cb(3, 4);
  cb << 1, 2, 3, 4, 4, 3, 2, 1, 1, 1, 1, 1;
  const Som s(HexLattice(1, 3), cb);
  const std::vector<double> x{2.5 * 4, 2.5 * 3, 999, 2.5 * 1};
  const std::vector<bool> mask{true, true, false, true};
  const auto m = s.bmu_masked(x, mask, true);
  EXPECT_EQ(m.unit, 1u);
  EXPECT_NEAR(m.scale, 2.5, 1e-12);
  EXPECT_NEAR(m.distance_sq, 0.0, 1e-9);
  std::vector<bool> allowed{true, false, true};
  EXPECT_NE(s.bmu_masked(x, mask, true, &allowed).unit, 1u);
  // Raw (not scale-invariant) matching with the masked point ignored.
  const std::vector<double> y{1, 2, -50, 4};
  EXPECT_EQ(s.bmu_masked(y, mask, false).unit, 0u);
}
