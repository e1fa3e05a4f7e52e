#include "core/pipeline/tyre_basis.hpp"

#include <fmt/format.h>

#include "core/curve_csv.hpp"

namespace brakefit::pipeline {

void add_tyre_results(EventResult& e, const Calibration& c, const gap::BenchModel& bm,
                      const Model* model, ForceSource force) {
  if (!e.event.fittable() || e.results.empty()) return;
  if (can::to_string(e.event.bench) != bm.condition) {
    e.tyre_notes.push_back(
        fmt::format("the bench model is of a {} bench and this event of a {} bench: not applied",
                    bm.condition, can::to_string(e.event.bench)));
    return;
  }
  gap::ConditionOptions co;
  co.force = force;
  // Every point the conditioning keeps: the per-event fit wants the whole curve, not the
  // diagnosis's decimation.
  co.max_points = 100'000;
  gap::TyrePoints pts;
  try {
    pts = gap::tyre_points(
        gap::condition(fmt::format("event {}", e.event.event_id), e.event, c, co), bm);
  } catch (const InputError& err) {
    e.tyre_notes.push_back(fmt::format("not conditioned for the tyre's fit: {}", err.what()));
    return;
  }
  for (const auto& [why, n] : pts.left_out)
    e.tyre_notes.push_back(n == 0
                               ? fmt::format("left out: {}", why)
                               : fmt::format("{} point{} left out: {}", n, n == 1 ? "" : "s", why));
  if (pts.curve.size() < kMinCurvePoints) {
    e.tyre_notes.push_back(
        fmt::format("{} of the tyre's points: too few to fit", pts.curve.size()));
    return;
  }
  e.tyre_max_slip_ratio = pts.curve.max_slip_ratio();
  const fit::MfFitOptions fo = fit_options_for(model);
  for (const auto& raw : e.results) {
    MethodResult t = run_method(raw.method, model, pts.curve, fo);
    t.basis = Basis::Tyre;
    flag_implausible(t, c.wheel_load_n);
    e.tyre_results.push_back(std::move(t));
  }
  e.tyre_curve = std::move(pts.curve);
}

}  // namespace brakefit::pipeline
