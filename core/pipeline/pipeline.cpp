#include "core/pipeline/pipeline.hpp"

#include <future>

#include "core/pipeline/tyre_basis.hpp"

namespace brakefit::pipeline {

Pipeline::Pipeline(const Calibration& c, const PipelineOptions& o, const Model* model)
    : cal_(c), opt_(o), model_(model), builder_(c), detector_(c, o.events) {}

void Pipeline::feed(const can::LoggedFrame& f) {
  if (auto s = builder_.feed(f)) feed(*s);
}

void Pipeline::feed(const Sample& s) {
  last_ = s;
  if (auto e = detector_.feed(s)) handle(std::move(*e));
}

void Pipeline::finish() {
  if (auto s = builder_.flush()) feed(*s);
  if (auto e = detector_.finish()) handle(std::move(*e));
}

void Pipeline::finish_file() {
  if (auto s = builder_.flush()) feed(*s);
  if (auto e = detector_.finish_file()) handle(std::move(*e));
}

void Pipeline::abort(const std::string& reason) {
  if (auto e = detector_.abort(reason)) handle(std::move(*e));
}

void Pipeline::handle(Event e) {
  if (opt_.defer_fit)
    closed_.push_back(std::move(e));
  else
    events_.push_back(fit(std::move(e), cal_));
}

EventResult Pipeline::fit(Event e, const Calibration& c) const {
  EventResult r;
  r.curve = event_curve(e, c, opt_.events, opt_.force);
  if (r.curve.size() < kMinCurvePoints && e.fittable()) e.flags.push_back("too_short");
  if (opt_.fit && e.fittable()) {
    const fit::MfFitOptions fo = fit_options_for(model_);
    std::vector<Method> methods;
    for (Method m : opt_.methods)
      if (m == Method::Lm || model_) methods.push_back(m);
    if (opt_.parallel_methods && methods.size() > 1) {
      std::vector<std::future<MethodResult>> jobs;
      jobs.reserve(methods.size());
      for (Method m : methods)
        jobs.push_back(std::async(std::launch::async,
                                  [&, m] { return run_method(m, model_, r.curve, fo, true); }));
      for (auto& j : jobs) r.results.push_back(j.get());
    } else {
      for (Method m : methods) r.results.push_back(run_method(m, model_, r.curve, fo));
    }
  }
  // A result no tyre could give is said with every output of it, never shown as a plain result.
  for (auto& m : r.results) flag_implausible(m, c.wheel_load_n);
  r.event = std::move(e);
  if (opt_.fit && opt_.bench_model) add_tyre_results(r, c, *opt_.bench_model, model_, opt_.force);
  return r;
}

}  // namespace brakefit::pipeline
