#pragma once
// Per-event fits on the tyre's basis: with a bench measurement model (brakefit gap --bench-model)
// each fittable event is conditioned as the diagnosis conditions it, the bench's effects are
// undone on its points, and the event's methods are fitted again to what is left.
#include <memory>

#include "core/gap/bench_model.hpp"
#include "core/pipeline/pipeline.hpp"

namespace brakefit::pipeline {

/// Fills e.tyre_results (one per method of e.results, basis tyre, implausible flagged) and
/// e.tyre_notes (points left out and why). An event of a bench other than the model's, or one
/// too short to condition, gets a note and no tyre results.
void add_tyre_results(EventResult& e, const Calibration& c, const gap::BenchModel& bm,
                      const Model* model, ForceSource force);

}  // namespace brakefit::pipeline
