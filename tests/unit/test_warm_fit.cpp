// The diagnosis's fitter (core/gap/warm_fit): its starts reach the tyre's basin where the
// baseline's curve took in an unmodelled force, and a fit of some of a set's runs that stops in a
// worse minimum than the same model's fit of all of them restarts from that fit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"

using namespace brakefit;

namespace {

/// Generator B's ground set of a heavy wheel alone (the fifth wheel's ripple kept or not),
/// diagnosed: the verdict must be the inertia alone, within `tolerance` of its magnitude.
gap::Report expect_the_inertia_alone(double inertia_kgm2, std::uint64_t seed, bool ref_ripple,
                                     double tolerance) {
  auto set = sim2::draw_set(can::BenchKind::Ground, "wheel_inertia", inertia_kgm2, seed);
  std::vector<gap::Run> runs;
  for (auto& run : set.runs) {
    if (!ref_ripple) run.tester.eccentricity_ref = 0;
    sim::append_event_csv_runs(runs, sim2::simulate_event_csv(run), "b");
  }
  auto rep =
      gap::diagnose(runs, sim::pooled_start(runs), gap::calibrated_options(gap::Condition::Ground));
  std::string notes;
  for (const auto& n : rep.notes) notes += "\n  note: " + n;
  EXPECT_EQ(rep.verdict, std::vector<std::string>{"wheel_inertia"}) << notes;
  const auto at = gap::param_offset(rep.accepted, gap::Effect::WheelInertia);
  EXPECT_TRUE(at);
  if (at) {
    EXPECT_NEAR(rep.after.params[*at], inertia_kgm2, tolerance * inertia_kgm2);
  }
  return rep;
}

}  // namespace

TEST(WarmFit, AFoldThatStopsInAWorseMinimumRestartsFromTheWholeSetsFit) {
  // Generator B's ground, a 2.69 kg m^2 wheel (seed 57005), the fifth wheel without its ripple:
  // the wheel's ripple and the inertia are all the set holds. Fitted on its two slower runs from
  // the baseline's and the neutral starts, the model stopped at E 0.96 (4 N in-sample against
  // 1.7 N for all three runs' fit) and the fastest run held out was 21 N off: the diagnosis said
  // `wheel_inertia, unexplained` at 12.4 N. Restarted from the fit of all three: 1.7 N.
  const auto rep = expect_the_inertia_alone(2.6876665591931785, 57005, false, 0.02);
  EXPECT_LT(rep.gap_after_rmse_n, 1.5 * rep.noise_n);
}

TEST(WarmFit, ABaselineFlattenedByAnUnmodelledForceAlsoStartsAtATyresShape) {
  // Generator B's ground, a 1.24 kg m^2 wheel (seed 57045): its inertial force rises on past the
  // tyre's peak, and the baseline took it into the curve's shape (E 0.94, D 5 570 N for a 4 250 N
  // tyre). From the baseline's and the neutral curve the inertia came out 0.73-1.06 kg m^2 at
  // E 0.95 (5.6 N a point), and the set was said `wheel_inertia, load_transfer, unexplained`.
  // From the baseline's curve with E at 0: 1.227 at E 0.10, on the floor.
  expect_the_inertia_alone(1.2399055259801168, 57045, true, 0.03);
}

namespace {

/// Three ground runs of one Magic Formula tyre that run on past the peak to 90 % slip (a channel
/// that shows the tyre through the runaway), with +-30 N of uniform noise.
std::vector<gap::Run> runs_to_the_lock(const MfParams& tyre) {
  std::vector<gap::Run> runs;
  std::uint64_t state = 1;
  auto noise_n = [&] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return (static_cast<double>(state >> 11) / 9007199254740992.0 - 0.5) * 60.0;
  };
  for (int k = 1; k <= 3; ++k) {
    gap::Run r;
    r.bench = can::BenchKind::Ground;
    for (int i = 0; i < 300; ++i) {
      const double runaway = i > 150 ? 1.0 + 0.1 * (i - 150) : 1.0;
      const double slip = std::min(0.9, 5e-4 * i * k * runaway);
      r.t_s.push_back(2e-3 * i * k);
      r.slip.push_back(slip);
      r.v_ref_mps.push_back(15.0);
      r.force_n.push_back(mf_force_n(tyre, slip) + noise_n());
      r.slip_sd.push_back(1e-4);
      r.pressure_rate_bar_per_s.push_back(50.0);
      r.ref_decel_mps2.push_back(5.0);
      r.wheel_accel_mps2.push_back(-5.0);
    }
    r.noise_n = 17.0;
    runs.push_back(std::move(r));
  }
  return runs;
}

}  // namespace

TEST(WarmFit, TheBaselineIsFittedFromTheCandidatesStartsSoNoCandidateScoresItsLocalMinimum) {
  // Runs to the lock have a second minimum, flat-topped (E near 1, C over 2), where a fit from a
  // flat-topped start stops (1.9e6 N^2 against 2.7e5 at the tyre). A baseline fitted from that
  // start alone stayed there while every candidate, fitted from the baseline's and the neutral
  // starts, left it: all seven were scored with that minimum's BIC drop, whatever their effect
  // (-380 to -449 on a null set of generator C's ground, which set the BIC gate other data were
  // held to).
  const MfParams tyre{18.2, 1.55, 7800.0, 0.26, 0, 0};
  const auto runs = runs_to_the_lock(tyre);
  const MfParams flat_topped{13.33, 2.117, 7757.0, 0.953, 0, 0};
  ASSERT_GT(gap::fit_runs(gap::pointers(runs), {}, flat_topped).params[3], 0.9);  // the trap
  auto o = gap::calibrated_options(gap::Condition::Ground);
  o.gate_gain = 1e9;  // every candidate scored, none taken
  const auto rep = gap::diagnose(runs, flat_topped, o);
  EXPECT_NEAR(rep.before.params[3], tyre.E, 0.05);
  for (const auto& e : rep.effects) EXPECT_GT(e.delta_bic, -40.0) << gap::to_string(e.effect);
  EXPECT_EQ(rep.verdict, std::vector<std::string>{"none"});
}
