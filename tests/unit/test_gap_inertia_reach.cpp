// From which wheel inertia a set's runs could show one (core/gap/inertia_reach.cpp): said where
// none is named, so that "none" is read against what the runs could tell.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"

using namespace brakefit;

namespace {

std::vector<gap::Run> null_runs(can::BenchKind bench, std::uint64_t seed) {
  const auto set = sim2::draw_set(bench, {}, seed);
  std::vector<gap::Run> runs;
  for (std::size_t k = 0; k < set.runs.size(); ++k)
    sim::append_event_csv_runs(runs, sim2::simulate_event_csv(set.runs[k]), fmt::format("r{}", k));
  return runs;
}

gap::Report diagnosed(const std::vector<gap::Run>& runs, gap::Condition c) {
  return gap::diagnose(runs, sim::pooled_start(runs), gap::calibrated_options(c));
}

bool has_note(const gap::Report& rep, const std::string& part) {
  return std::any_of(rep.notes.begin(), rep.notes.end(),
                     [&](const std::string& n) { return n.find(part) != std::string::npos; });
}

}  // namespace

TEST(GapInertiaReach, TheRollerHidesAnInertiaTheRoadShows) {
  // At 5 km/h the wheel decelerates little before it runs away, and the curve's B, C, D, E take
  // most of what it does; on the road it decelerates with the vehicle.
  const auto roller = diagnosed(null_runs(can::BenchKind::Roller, 77), gap::Condition::Roller);
  const auto ground = diagnosed(null_runs(can::BenchKind::Ground, 77), gap::Condition::Ground);
  ASSERT_TRUE(std::isfinite(roller.inertia_reach_kgm2)) << roller.inertia_reach_kgm2;
  ASSERT_TRUE(std::isfinite(ground.inertia_reach_kgm2)) << ground.inertia_reach_kgm2;
  EXPECT_GT(roller.inertia_reach_kgm2, 0.0);
  EXPECT_GT(ground.inertia_reach_kgm2, 0.0);
  EXPECT_GT(roller.inertia_reach_kgm2, 3 * ground.inertia_reach_kgm2)
      << roller.inertia_reach_kgm2 << " vs " << ground.inertia_reach_kgm2;
  EXPECT_TRUE(has_note(roller, "could show one only from about")) << roller.notes.size();
}

TEST(GapInertiaReach, GrowsWithTheFloorAndTheGateAndIsInfiniteWithoutDeceleration) {
  const auto runs = null_runs(can::BenchKind::Roller, 78);
  const auto rep = diagnosed(runs, gap::Condition::Roller);
  const auto at = [&](double noise_n, double gate) {
    return gap::inertia_reach(runs, rep.before.params, rep.baseline_effects, noise_n, gate);
  };
  const double base = at(rep.noise_n, 0.1).smallest_kgm2;
  ASSERT_TRUE(std::isfinite(base));
  EXPECT_NEAR(at(2 * rep.noise_n, 0.1).smallest_kgm2, 2 * base, 1e-9 * base);
  EXPECT_GT(at(rep.noise_n, 0.2).smallest_kgm2, base);
  EXPECT_GT(at(rep.noise_n, 0.1).max_decel_mps2, 0.0);
  // A wheel that never decelerates holds no inertia's force: no inertia could be shown.
  auto still = runs;
  for (auto& r : still) std::fill(r.wheel_accel_mps2.begin(), r.wheel_accel_mps2.end(), 0.0);
  EXPECT_TRUE(std::isinf(
      gap::inertia_reach(still, rep.before.params, rep.baseline_effects, rep.noise_n, 0.1)
          .smallest_kgm2));
  // Nor a gate that passes everything or nothing.
  EXPECT_TRUE(std::isinf(at(rep.noise_n, 0.0).smallest_kgm2));
  EXPECT_TRUE(std::isinf(at(rep.noise_n, 1.0).smallest_kgm2));
}
