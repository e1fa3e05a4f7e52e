#include <gtest/gtest.h>

#include <cmath>

#include "core/mlp/mlp.hpp"
#include "core/rng.hpp"

using namespace brakefit;
using namespace brakefit::mlp;

namespace {

void known_mapping(std::size_t n, std::uint64_t seed, Eigen::MatrixXd& x, Eigen::MatrixXd& y) {
  Rng rng(seed);
  x.resize(static_cast<Eigen::Index>(n), 2);
  y.resize(static_cast<Eigen::Index>(n), 2);
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    const double a = rng.uniform(-2, 2), b = rng.uniform(-2, 2);
    x.row(i) << a, b;
    y.row(i) << std::sin(a) + 0.3 * b * b, a * b;
  }
}

}  // namespace

TEST(Mlp, GradientMatchesFiniteDifferences) {
  Network net({3, 5, 4, 2}, 7);
  Rng rng(8);
  Eigen::MatrixXd xt(3, 6), yt(2, 6);
  for (Eigen::Index i = 0; i < xt.size(); ++i) xt(i) = rng.uniform(-1, 1);
  for (Eigen::Index i = 0; i < yt.size(); ++i) yt(i) = rng.uniform(-1, 1);
  const Eigen::VectorXd g = net.gradient(xt, yt, nullptr);
  const Eigen::VectorXd w = net.parameters();
  for (Eigen::Index k = 0; k < w.size(); ++k) {
    Eigen::VectorXd wp = w, wm = w;
    wp(k) += 1e-6;
    wm(k) -= 1e-6;
    double fp = 0, fm = 0;
    net.set_parameters(wp);
    net.gradient(xt, yt, &fp);
    net.set_parameters(wm);
    net.gradient(xt, yt, &fm);
    EXPECT_NEAR(g(k), (fp - fm) / 2e-6, 1e-7) << "weight " << k;
  }
}

TEST(Mlp, EachTrainerLearnsAKnownMapping) {
  Eigen::MatrixXd x, y, xtest, ytest;
  known_mapping(600, 1, x, y);
  known_mapping(300, 2, xtest, ytest);
  const Scaler sx = Scaler::fit(x), sy = Scaler::fit(y);
  for (Trainer t : {Trainer::Rprop, Trainer::GradientDescent, Trainer::LevenbergMarquardt}) {
    TrainSettings s;
    s.trainer = t;
    s.hidden = {12};
    s.max_epochs = t == Trainer::LevenbergMarquardt ? 150 : (t == Trainer::Rprop ? 1500 : 4000);
    s.learning_rate = 0.05;
    s.patience = 400;
    Network net({2, 12, 2}, 3);
    const TrainReport rep = train(net, sx.apply(x), sy.apply(y), s);
    const Eigen::MatrixXd pred = sy.invert(net.predict(sx.apply(xtest)));
    const double mse = (pred - ytest).squaredNorm() / static_cast<double>(ytest.size());
    const double var = (ytest.rowwise() - ytest.colwise().mean()).squaredNorm() /
                       static_cast<double>(ytest.size());
    EXPECT_LT(mse / var, t == Trainer::GradientDescent ? 0.05 : 0.01)
        << to_string(t) << " after " << rep.epochs;
    EXPECT_GT(rep.best_epoch, 0u);
  }
}

TEST(Mlp, EarlyStoppingKeepsTheBestValidationWeights) {
  // Pure noise targets: the validation error cannot keep improving, so training stops early.
  Rng rng(9);
  Eigen::MatrixXd x(200, 3), y(200, 1);
  for (Eigen::Index i = 0; i < x.size(); ++i) x(i) = rng.normal();
  for (Eigen::Index i = 0; i < y.size(); ++i) y(i) = rng.normal();
  TrainSettings s;
  s.hidden = {30};
  s.max_epochs = 5000;
  s.patience = 30;
  Network net({3, 30, 1}, 4);
  const TrainReport rep = train(net, x, y, s);
  EXPECT_TRUE(rep.early_stopped);
  EXPECT_LT(rep.epochs, 5000u);
  EXPECT_EQ(rep.epochs, rep.best_epoch + s.patience);
}

TEST(Mlp, ScalerRoundTrip) {
  Eigen::MatrixXd x(4, 2);
  x << 1, 10, 2, 10, 3, 10, 4, 10;  // second column constant
  const Scaler s = Scaler::fit(x);
  const Eigen::MatrixXd z = s.apply(x);
  EXPECT_NEAR(z.col(0).mean(), 0.0, 1e-12);
  EXPECT_NEAR(z.col(0).squaredNorm() / 4, 1.0, 1e-12);
  EXPECT_TRUE(z.col(1).isZero());
  EXPECT_TRUE(s.invert(z).isApprox(x));
}
