// predict()'s cache across a fit's evaluations (core/gap/predict_cache.hpp): what it keeps is the
// same computation's result, bit for bit, so a fit takes the same steps with it as without it.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "core/gap/predict_cache.hpp"

using namespace brakefit;

namespace {

/// A 2 s ground-like run at 500 Hz: slip ramping to 0.15, the reference slowing from 20 m/s, a
/// deceleration that rises and rings, a declared pressure filter.
gap::Run ringing_run() {
  gap::Run r;
  r.bench = can::BenchKind::Ground;
  r.pressure_filter_s = 0.03;
  r.brake_gain_n_per_bar = 400.0;
  for (int i = 0; i < 1000; ++i) {
    const double t = i * 2e-3;
    r.t_s.push_back(t);
    r.slip.push_back(0.15 * std::min(1.0, t / 1.2));
    r.v_ref_mps.push_back(20.0 - 6.0 * t);
    r.ref_decel_mps2.push_back(6.0 * (1 - std::exp(-t / 0.1)) * (1 + 0.1 * std::sin(9 * t)));
    r.wheel_accel_mps2.push_back(-6.5);
    r.pressure_rate_bar_per_s.push_back(t < 1.2 ? 40.0 : 0.0);
    r.force_n.push_back(3000.0 * std::min(1.0, t / 1.2));
  }
  r.initial_force_n = r.force_n.front();
  return r;
}

}  // namespace

TEST(PredictCache, AValueIsComputedOncePerRunKindAndArguments) {
  const gap::Run a = ringing_run(), b = ringing_run();
  gap::PredictCache cache;
  int made = 0;
  const auto make = [&] {
    ++made;
    return std::vector<double>{static_cast<double>(made)};
  };
  using K = gap::PredictCache::Kind;
  EXPECT_EQ(cache.get(a, K::Pitch, 0.1, 0.02, make).front(), 1.0);
  EXPECT_EQ(cache.get(a, K::Pitch, 0.1, 0.02, make).front(), 1.0);  // kept
  EXPECT_EQ(made, 1);
  EXPECT_EQ(cache.get(b, K::Pitch, 0.1, 0.02, make).front(), 2.0);       // another run
  EXPECT_EQ(cache.get(a, K::Relax, 0.1, 0.02, make).front(), 3.0);       // another kind
  EXPECT_EQ(cache.get(a, K::Pitch, 0.1, 0.0200001, make).front(), 4.0);  // another argument
  EXPECT_EQ(made, 4);
  // Past its room the least recently asked value of a kind gives way; the others stay.
  const int room = static_cast<int>(gap::PredictCache::kPerKind);
  for (int k = 0; k < room - 1; ++k) cache.get(a, K::Pitch, 1.0 + k, 0.0, make);
  EXPECT_EQ(made, 4 + room - 1);
  EXPECT_EQ(cache.get(a, K::Relax, 0.1, 0.02, make).front(), 3.0);
  EXPECT_EQ(cache.get(a, K::Pitch, 0.1, 0.0200001, make).front(), 4.0);  // asked after 0.02
  EXPECT_EQ(made, 4 + room - 1);
  EXPECT_EQ(cache.get(a, K::Pitch, 0.1, 0.02, make).front(), 4.0 + room);  // the oldest went
}

TEST(PredictCache, PredictWithItIsPredictWithoutItBitForBit) {
  // A Jacobian's central differences: each parameter in turn a step up and down from the point,
  // the model carrying all three kinds kept (a load with its pitch, a relaxation, the filter).
  const gap::Run r = ringing_run();
  const std::vector<gap::Effect> model{gap::Effect::RelaxationLength, gap::Effect::LoadTransfer};
  ASSERT_EQ(gap::param_count(model), 4u + 1u + 4u);
  const std::vector<double> x{12.0, 1.6, 3200.0, 0.4, 0.35, 0.02, 1.3, 0.08, 0.016};
  gap::PredictCache cache;
  std::vector<std::vector<double>> points{x};
  for (std::size_t k = 0; k < x.size(); ++k)
    for (const double sign : {1.0, -1.0}) {
      std::vector<double> p = x;
      p[k] += sign * 1e-6 * std::max(1.0, std::abs(x[k]));
      points.push_back(p);
    }
  points.push_back(x);  // and the point again, after every perturbation
  for (std::size_t i = 0; i < points.size(); ++i) {
    const std::vector<double> with = gap::predict(r, points[i], model, &cache);
    const std::vector<double> without = gap::predict(r, points[i], model);
    ASSERT_EQ(with.size(), without.size());
    for (std::size_t j = 0; j < with.size(); ++j)
      ASSERT_EQ(with[j], without[j]) << "evaluation " << i << ", sample " << j;
  }
  // The load, the relaxation and the filter each move the prediction: all three were exercised.
  const auto plain = gap::predict(r, std::vector<double>(x.begin(), x.begin() + 4), {});
  EXPECT_NE(gap::predict(r, x, model), plain);
}
