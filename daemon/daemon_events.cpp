// A finished event's way out: committed to the store first, then published in the event block
// (retried with a backoff while the store fails); the newest stored event restored at start.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <ctime>

#include "core/event_json.hpp"
#include "daemon/daemon.hpp"
#include "daemon/event_block.hpp"

namespace brakefit::daemon {

void Daemon::publish_finished(Clock::time_point closed) {
  auto finished = pipeline_->take_events();
  if (finished.empty()) return;
  for (auto& er : finished) {
    const Model* model = model_.get();
    auto doc = event_json(er, source_->describe(), model);
    doc["vehicle_id"] = vehicle_id_;
    ++events_finished_;
    if (!er.event.flags.empty()) ++events_flagged_;
    const MethodResult* best = er.results.empty() ? nullptr : &er.results.back();
    spdlog::info(
        "event {} ({}): {} points, ended by {}{}{}", er.event.event_id,
        can::to_string(er.event.bench), er.curve.size(), er.event.end_reason,
        er.event.flags.empty() ? "" : fmt::format(" [{}]", fmt::join(er.event.flags, ",")),
        best ? fmt::format(", {} B {:.3f} C {:.4f} D {:.1f} E {:.4f}", to_string(best->method),
                           best->params.B, best->params.C, best->params.D, best->params.E)
             : "");
    pending_->push(make_record(er, doc.dump(), pipeline::format_calibration(cfg_.calibration),
                               vehicle_id_, source_->describe(), model ? model->hash : "",
                               static_cast<std::int64_t>(std::time(nullptr))));
  }
  commit_pending(closed, true);
}

void Daemon::commit_pending(Clock::time_point closed, bool fresh) {
  const auto now = Clock::now();
  if (pending_->size() == 0 || (!fresh && now < next_retry_)) return;
  while (const EventRecord* r = pending_->front()) {
    const bool spilled = pending_->front_is_spilled();
    bool samples_stored = false;
    std::optional<std::int64_t> id;
    if (spilled) {
      if ((id = store_->find(*r))) samples_stored = store_->get(*id)->samples_stored;
    }
    if (!id) id = store_->commit(*r, &samples_stored);
    if (!id) {
      // 1. durable first: not stored, so not published. Retried with a backoff.
      ++store_failures_;
      if (!store_error_ || retry_delay_s_ >= cfg_.store.retry_max_s)
        spdlog::error("{}; {} event(s) waiting, retrying", store_->error(), pending_->size());
      store_error_ = true;
      pending_->spill_excess();
      next_retry_ = now + std::chrono::duration_cast<Clock::duration>(
                              std::chrono::duration<double>(retry_delay_s_));
      retry_delay_s_ = std::min(retry_delay_s_ * 2.0, cfg_.store.retry_max_s);
      return;
    }
    if (store_error_) spdlog::info("store works again: event {} committed", *id);
    store_error_ = false;
    retry_delay_s_ = 0.1;
    // 2. then published: the block is built from what was stored.
    try {
      server_->post(event_block(r->result_json, *id, samples_stored), closed);
    } catch (const std::exception& e) {
      spdlog::error("event {}: stored but its block cannot be built: {}", *id, e.what());
    }
    spdlog::debug("event {} stored and published {:.2f} ms after it closed", *id,
                  std::chrono::duration<double, std::milli>(Clock::now() - closed).count());
    pending_->pop();
  }
}

void Daemon::restore_last_event() {
  const auto last = store_->last();
  if (!last) return;
  try {
    server_->post(event_block(last->result_json, last->id, last->samples_stored));
    spdlog::info("last stored event {} restored into the registers (seq {})", last->id,
                 event_seq(last->id));
  } catch (const std::exception& e) {
    spdlog::warn("last stored event {} cannot be shown in the registers: {}", last->id, e.what());
  }
}

}  // namespace brakefit::daemon
