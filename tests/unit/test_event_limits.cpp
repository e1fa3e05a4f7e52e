// Events that must end however the data behaves: at their maximum length (a pressure stuck on,
// a test never switched off), at an implausible reading (never fitted, never silent), and the
// daemon's deferred fit giving exactly the results of the fit made as the event closes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/pipeline/event_csv.hpp"
#include "core/pipeline/pipeline.hpp"

using namespace brakefit;
using namespace brakefit::pipeline;

namespace {

Sample at(int i, double v_ref, double v_wheel, double p_bar) {
  Sample s;
  s.t_ns = static_cast<std::int64_t>(i) * 1'000'000;
  s.v_ref_mps = v_ref;
  s.v_wheel_mps = v_wheel;
  s.pressure_bar = p_bar;
  s.state = can::TestState::Measuring;
  return s;
}

bool has(const Event& e, const std::string& flag) {
  return std::find(e.flags.begin(), e.flags.end(), flag) != e.flags.end();
}

}  // namespace

TEST(EventLimits, AnEventThatNeverEndsEndsAtMaxEventSeconds) {
  EventSettings es;
  es.max_event_s = 2.0;
  EventDetector det(Calibration{}, es);
  std::optional<Event> ev;
  int i = 0;
  for (; i < 10'000 && !ev; ++i) ev = det.feed(at(i, 1.39, 1.39 * 0.9, 3.0));  // stuck at 3 bar
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->end_reason, "max_length");
  EXPECT_TRUE(has(*ev, "aborted"));
  EXPECT_NEAR(static_cast<double>(i), 2001.0, 2.0);  // 1 kHz: 2 s after the start
  EXPECT_NE(ev->note.find("max_event_s"), std::string::npos);
}

TEST(EventLimits, AnImplausibleReadingEndsTheEventFlaggedAndNeverStartsOne) {
  const double huge = 1e308, nan = std::numeric_limits<double>::quiet_NaN();
  for (const Sample& bad : {at(100, huge, 1.0, 5.0), at(100, 1.39, -5.0, 5.0),
                            at(100, 1.39, 1.3, 9000.0), at(100, nan, 1.3, 5.0)}) {
    EventDetector det(Calibration{}, EventSettings{});
    std::optional<Event> ev;
    for (int i = 0; i < 100; ++i) ASSERT_FALSE(det.feed(at(i, 1.39, 1.39 * (1 - 0.001 * i), 5.0)));
    ev = det.feed(bad);
    ASSERT_TRUE(ev);
    EXPECT_EQ(ev->end_reason, "implausible_data");
    EXPECT_TRUE(has(*ev, "implausible_data"));
    EXPECT_FALSE(ev->fittable());
    EXPECT_EQ(ev->samples.size(), 100u);  // the implausible sample is not in it
    EXPECT_NE(ev->note.find("outside"), std::string::npos) << ev->note;
  }
  // Implausible readings with the brake on start nothing.
  EventDetector det(Calibration{}, EventSettings{});
  for (int i = 0; i < 100; ++i) EXPECT_FALSE(det.feed(at(i, huge, 1.0, 5.0)));
  EXPECT_FALSE(det.active());
}

TEST(EventLimits, TheDeferredFitGivesTheResultsOfTheFitMadeAtTheClose) {
  Calibration cal;
  PipelineOptions now, deferred;
  now.methods = deferred.methods = {Method::Lm};
  deferred.defer_fit = true;
  Pipeline a(cal, now, nullptr), b(cal, deferred, nullptr);
  for (int i = 0; i < 3000; ++i) {
    const double slip = 0.27 * i / 2000.0;
    const auto s = at(i, 1.39, 1.39 * (1 - slip), i < 2990 ? 0.02 * i + 2.0 : 0.0);
    a.feed(s);
    b.feed(s);
  }
  auto fitted = a.take_events();
  auto closed = b.take_closed();
  ASSERT_EQ(fitted.size(), 1u);
  ASSERT_EQ(closed.size(), 1u);
  EXPECT_TRUE(b.take_events().empty());  // nothing fitted behind the caller's back
  const auto later = b.fit(std::move(closed[0]), cal);
  ASSERT_EQ(later.results.size(), 1u);
  ASSERT_EQ(fitted[0].results.size(), 1u);
  EXPECT_EQ(later.results[0].params.B, fitted[0].results[0].params.B);
  EXPECT_EQ(later.results[0].params.D, fitted[0].results[0].params.D);
  EXPECT_EQ(later.event.end_reason, fitted[0].event.end_reason);
}

TEST(TyreLimits, APeakFrictionOrAShapeNoTyreGivesIsNamed) {
  const MfParams tyre{15.0, 1.6, 4000.0, 0.3};
  EXPECT_TRUE(implausible_curve(tyre, 3800.0).empty());  // peak friction 1.05
  const auto heavy = implausible_curve({18.45, 1.6, 13560.0, -4.0}, 3800.0);
  ASSERT_EQ(heavy.size(), 1u);
  EXPECT_NE(heavy[0].find("peak friction 3.57"), std::string::npos) << heavy[0];
  const auto flat = implausible_curve({18.45, 0.3, 4000.0, -4.0}, 3800.0);
  ASSERT_FALSE(flat.empty());
  EXPECT_NE(flat[0].find("shape factor C 0.3"), std::string::npos) << flat[0];
  EXPECT_TRUE(implausible_curve({15.0, 1.6, 13560.0, 0.3}, std::nan("")).empty());  // no load
  EXPECT_EQ(implausible_curve({15.0, 1.6, 100.0, 0.3}, 3800.0).size(), 1u);         // 0.026
}

TEST(TyreLimits, AnEventsFitIsJudgedAgainstItsWheelLoad) {
  Calibration cal;
  cal.wheel_load_n = 1000.0;  // the ramp's forces reach several times this load
  PipelineOptions o;
  o.methods = {Method::Lm};
  Pipeline p(cal, o, nullptr);
  for (int i = 0; i < 3000; ++i) {
    const double slip = 0.27 * i / 2000.0;
    p.feed(at(i, 1.39, 1.39 * (1 - slip), i < 2990 ? 0.02 * i + 2.0 : 0.0));
  }
  auto ev = p.take_events();
  ASSERT_EQ(ev.size(), 1u);
  ASSERT_EQ(ev[0].results.size(), 1u);
  ASSERT_FALSE(ev[0].results[0].implausible.empty());
  EXPECT_NE(ev[0].results[0].implausible.back().find("peak friction"), std::string::npos);
}

TEST(EventLimits, AnAirBrakedExportStartsAtItsOwnRiseNotAtTwoBar) {
  // A heavy vehicle's export: air brakes, the wheel at its peak by 2.4 bar. At the configured 2 bar
  // start its event held the last few samples before the lock (too_short); scaled to a tenth of
  // its largest pressure it starts at the rise.
  Calibration cal;
  cal.bench = can::BenchKind::Ground;
  cal.wheel_radius_m = 0.5;
  cal.brake_gain_n_per_bar = 9000;
  EventCsv air, hydraulic;
  for (int i = 0; i <= 300; ++i) {
    const double p = std::max(0.0, 0.01 * (i - 50));  // 10 bar/s from 0.05 s
    const double slip = std::min(0.9, 0.03 * p);
    air.samples.push_back(at(i, 20.0, 20.0 * (1 - slip), p));
    hydraulic.samples.push_back(at(i, 20.0, 20.0, 30 * p));
  }
  const EventSettings base;
  const EventSettings s = event_csv_settings(air, base);
  EXPECT_NEAR(s.start_pressure_bar, 0.25, 1e-9);
  EXPECT_NEAR(s.release_pressure_bar, 0.125, 1e-9);
  EXPECT_EQ(event_csv_settings(hydraulic, base).start_pressure_bar, base.start_pressure_bar);
  auto samples_of = [&](const EventSettings& es) {
    PipelineOptions o;
    o.fit = false;
    o.events = es;
    Pipeline p(cal, o, nullptr);
    for (const auto& smp : air.samples) p.feed(smp);
    p.finish_file();
    std::size_t n = 0;
    for (const auto& e : p.events()) n = std::max(n, e.event.samples.size());
    return n;
  };
  EXPECT_GT(samples_of(s), samples_of(base) + 150);
}
