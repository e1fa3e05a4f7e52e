// The effects outside the gap catalogue generators A and B inject (a pressure transducer's bow,
// friction fading with the energy slid): each follows its law, and the diagnosis gives them no
// catalogue name.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/pipeline/event_csv.hpp"
#include "sim/referee.hpp"
#include "sim/scenario.hpp"
#include "sim/second/generator.hpp"

using namespace brakefit;

namespace {

/// The pressure channel of a run with its transducer's noise and steps taken out.
std::vector<double> clean_pressure(sim2::RunCase run) {
  run.tester.pressure_noise_bar = run.tester.pressure_step_bar = 0;
  const auto csv = pipeline::parse_event_csv(sim2::simulate_event_csv(run), "b.csv");
  std::vector<double> p;
  for (const auto& s : csv.samples) p.push_back(s.pressure_bar);
  return p;
}

double peak(const std::vector<double>& p) {
  return *std::max_element(p.begin(), p.end());
}

}  // namespace

TEST(OutsideCatalogue, APressureTransducersBowFollowsItsLaw) {
  // The bow moves the reading only: the wheel, the line and the stamps are as without it.
  const double a = 0.02;
  const auto bowed = sim2::draw_set(can::BenchKind::Roller, "pressure_bow", a, 3);
  const auto plain = sim2::draw_set(can::BenchKind::Roller, "none", 0.0, 3);
  const auto pb = clean_pressure(bowed.runs[1]), pp = clean_pressure(plain.runs[1]);
  ASSERT_EQ(pb.size(), pp.size());
  const double p_fs = plain.runs[1].max_pressure_bar;
  double largest = 0;
  for (std::size_t i = 0; i < pp.size(); ++i) {
    const double x = pp[i] / p_fs;
    // The export writes the pressure to 1 mbar.
    EXPECT_NEAR(pb[i] - pp[i], 4 * a * p_fs * x * (1 - x), 1.5e-3) << "sample " << i;
    largest = std::max(largest, pb[i] - pp[i]);
  }
  EXPECT_GT(largest, 0.03 * peak(pp));  // a bow the force channel shows
}

TEST(OutsideCatalogue, FrictionFadesWithTheEnergySlidMostOnTheSlowestRamp) {
  const auto faded = sim2::draw_set(can::BenchKind::Roller, "friction_fade", 1.0, 3);
  const auto plain = sim2::draw_set(can::BenchKind::Roller, "none", 0.0, 3);
  std::vector<double> ratio;  // the run's peak force with the fade over without
  for (std::size_t k = 0; k < plain.runs.size(); ++k)
    ratio.push_back(peak(clean_pressure(faded.runs[k])) / peak(clean_pressure(plain.runs[k])));
  // The referee's cars: ramps of about 10, 25 and 60 bar/s; the slow ramp slides longest.
  ASSERT_EQ(ratio.size(), 3u);
  EXPECT_LT(ratio[2], 0.995);
  EXPECT_LT(ratio[0], ratio[1]);
  EXPECT_LT(ratio[1], ratio[2]);
  EXPECT_GT(ratio[0], 0.7);
}

TEST(OutsideCatalogue, NeitherIsGivenACatalogueName) {
  // A bow maps the force through a smooth monotone function of itself: the fitted curve takes it
  // (`none`, the published curve the transducer's). A fade that differs between the ramps leaves a
  // gap no catalogue effect takes: `unexplained`.
  const gap::Options o = gap::calibrated_options(gap::Condition::Roller);
  const auto bow =
      sim::run_trial(sim::draw_outside(0, gap::Condition::Roller), sim::outside_seed(0), o);
  EXPECT_EQ(bow.truth.effect, "pressure_bow");
  EXPECT_TRUE(bow.correct()) << bow.verdict.front();
  const auto fade =
      sim::run_trial(sim::draw_outside(1, gap::Condition::Roller), sim::outside_seed(1), o);
  EXPECT_EQ(fade.truth.effect, "friction_fade");
  ASSERT_FALSE(fade.verdict.empty());
  EXPECT_EQ(fade.verdict.front(), "unexplained");
  EXPECT_GT(fade.gap_before_n, 3 * fade.noise_n);
  // A name on such a set is a false claim.
  sim::TrialResult claim = fade;
  claim.verdict = {"slip_offset"};
  EXPECT_FALSE(claim.correct());
}

TEST(OutsideCatalogue, GeneratorAsFadeIsUnexplainedAndItsScenarioReadsBoth) {
  const auto s = sim::parse_scenario(
      "[scenario]\nbench = \"roller\"\n[effects]\nfade_per_m = 1.0\npressure_bow_ratio = -0.01\n",
      "f.toml");
  EXPECT_EQ(s.effects.fade_per_m, 1.0);
  EXPECT_EQ(s.effects.pressure_bow_ratio, -0.01);
  EXPECT_THROW(sim::parse_scenario("[effects]\npressure_bow_ratio = 0.5\n", "f.toml"), InputError);
  const auto fade =
      sim::run_trial(sim::draw_outside(1, gap::Condition::Roller, sim::Generator::A),
                     sim::outside_seed(1), gap::calibrated_options(gap::Condition::Roller));
  ASSERT_FALSE(fade.verdict.empty());
  EXPECT_EQ(fade.verdict.front(), "unexplained");
  EXPECT_GT(fade.gap_before_n, 3 * fade.noise_n);
}
