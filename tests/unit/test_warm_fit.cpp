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
