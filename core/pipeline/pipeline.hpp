#pragma once
// The replay/live pipeline: frames (or samples) in, finished and fitted brake events out. The same
// code runs in `brakefit replay` and, later, inside brakefitd.
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/curve_csv.hpp"
#include "core/gap/bench_model.hpp"
#include "core/identify.hpp"
#include "core/pipeline/events.hpp"

namespace brakefit::pipeline {

struct PipelineOptions {
  EventSettings events;
  ForceSource force = ForceSource::Pressure;
  std::vector<Method> methods{Method::Som, Method::Mlp, Method::Lm, Method::Hybrid};
  bool fit = true;  ///< false: detection only (throughput measurement)
  /// Run the methods of one event concurrently (the daemon: shorter event-end to publish latency).
  /// Results are identical either way; each method reads the model only.
  bool parallel_methods = false;
  /// Closed events are handed over unfitted (take_closed), for the caller to make them durable
  /// before the fit, then fitted with fit(): the daemon's journal. false: fitted as they close.
  bool defer_fit = false;
  /// A bench's measurement model: each event is fitted again with its effects undone
  /// (EventResult::tyre_results, tyre_basis.hpp). Null: the instrument's fits only.
  std::shared_ptr<const gap::BenchModel> bench_model;
};

struct EventResult {
  Event event;
  Curve curve;
  std::vector<MethodResult> results;  ///< empty for flagged events
  /// The same methods on the tyre's points (a bench model's effects undone; empty without one),
  /// and what was left out of those points and why.
  std::vector<MethodResult> tyre_results;
  std::vector<std::string> tyre_notes;
  Curve tyre_curve;                  ///< the tyre's points the tyre_results were fitted to
  double tyre_max_slip_ratio = NAN;  ///< the largest slip of the tyre's points (NaN: none)
};

class Pipeline {
 public:
  Pipeline(const Calibration& c, const PipelineOptions& o, const Model* model);
  void feed(const can::LoggedFrame& f);
  void feed(const Sample& s);
  /// End of a log: a running event is aborted (end_of_data).
  void finish();
  /// End of an event file: a running event is finished (end_of_file).
  void finish_file();
  /// Ends a running event, flagged aborted with this end reason.
  void abort(const std::string& reason);
  void arm() { detector_.arm(); }
  bool event_active() const { return detector_.active(); }
  const std::optional<Sample>& last_sample() const { return last_; }
  std::vector<EventResult>& events() { return events_; }
  /// Hands over the finished events (the daemon drains them after every frame).
  std::vector<EventResult> take_events() { return std::exchange(events_, {}); }
  /// With defer_fit: the events closed since the last call, not fitted yet.
  std::vector<Event> take_closed() { return std::exchange(closed_, {}); }
  /// Fits one closed event with this pipeline's options and model, on calibration c (an event
  /// journaled under another calibration is fitted with its own).
  EventResult fit(Event e, const Calibration& c) const;
  const Calibration& calibration() const { return cal_; }
  const SampleStats& sample_stats() const { return builder_.stats(); }

 private:
  void handle(Event e);
  Calibration cal_;
  PipelineOptions opt_;
  const Model* model_;
  SampleBuilder builder_;
  EventDetector detector_;
  std::vector<EventResult> events_;
  std::vector<Event> closed_;
  std::optional<Sample> last_;
};

}  // namespace brakefit::pipeline
