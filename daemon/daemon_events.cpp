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
  auto events = pipeline_->take_closed();
  if (events.empty()) return;
  const std::string calibration = pipeline::format_calibration(pipeline_->calibration());
  for (auto& ev : events) {
    // 1. Durable as it closes: the raw event goes to its journal file before the fit, so a kill
    //    from here on leaves the file, which the next start fits and commits.
    pipeline::EventResult closed_only;
    closed_only.event = std::move(ev);  // moved on to the fit below, not copied
    const auto& e = closed_only.event;
    EventRecord journaled =
        make_record(closed_only, "", calibration, vehicle_id_, source_->describe(),
                    model_ ? model_->hash : "", static_cast<std::int64_t>(std::time(nullptr)));
    const auto t0 = Clock::now();
    std::string path = pending_->journal(journaled);
    spdlog::info(
        "event {} closed ({}): {}", e.event_id, e.end_reason,
        path.empty()
            ? std::string("not journaled, held in memory")
            : fmt::format("journaled to {} in {:.2f} ms", path,
                          std::chrono::duration<double, std::milli>(Clock::now() - t0).count()));
    // 2. Fitted, then kept under the journal's uid (a restart finds the row it may have become).
    EventRecord r = fitted_record(
        pipeline_->fit(std::move(closed_only.event), pipeline_->calibration()), calibration,
        vehicle_id_, source_->describe(), journaled.created_unix_s, true);
    r.uid = journaled.uid;
    pending_->push(std::move(r), std::move(path));
  }
  commit_pending(closed, true);
}

EventRecord Daemon::fitted_record(const pipeline::EventResult& er, const std::string& calibration,
                                  const std::string& vehicle_id, const std::string& source,
                                  std::int64_t created_unix_s, bool count) {
  const Model* model = model_.get();
  auto doc = event_json(er, source, model);
  doc["vehicle_id"] = vehicle_id;
  if (count) {
    ++events_finished_;
    if (!er.event.flags.empty()) ++events_flagged_;
  }
  // The fits published: the tyre's when a bench measurement model gave them.
  const auto& published = er.tyre_results.empty() ? er.results : er.tyre_results;
  const MethodResult* best = published.empty() ? nullptr : &published.back();
  spdlog::info("event {} ({}): {} points, ended by {}{}{}", er.event.event_id,
               can::to_string(er.event.bench), er.curve.size(), er.event.end_reason,
               er.event.flags.empty() ? "" : fmt::format(" [{}]", fmt::join(er.event.flags, ",")),
               best ? fmt::format(", {} B {:.3f} C {:.4f} D {:.1f} E {:.4f} ({} basis)",
                                  to_string(best->method), best->params.B, best->params.C,
                                  best->params.D, best->params.E, to_string(best->basis))
                    : "");
  return make_record(er, doc.dump(), calibration, vehicle_id, source, model ? model->hash : "",
                     created_unix_s);
}

/// A journaled event that closed before a crash is fitted now, with its own calibration.
bool Daemon::fit_journaled(const EventRecord& r) {
  try {
    const auto cal = pipeline::parse_calibration(r.calibration_toml, "journaled event " + r.uid);
    EventRecord f = fitted_record(pipeline_->fit(event_from_record(r), cal), r.calibration_toml,
                                  r.vehicle_id, r.source, r.created_unix_s, false);
    f.uid = r.uid;
    spdlog::info("event (pipeline id {}) closed before the last stop, fitted from its journal",
                 r.pipeline_event_id);
    pending_->replace_front(std::move(f));
    return true;
  } catch (const std::exception& e) {
    spdlog::error("journaled event {} cannot be fitted: {}", r.uid, e.what());
    return false;
  }
}

void Daemon::commit_pending(Clock::time_point closed, bool fresh) {
  const auto now = Clock::now();
  if (pending_->size() == 0 || (!fresh && now < next_retry_)) return;
  while (const EventRecord* r = pending_->front()) {
    if (!fitted(*r) && !fit_journaled(*r)) {
      pending_->drop_front_aside("it cannot be fitted");
      continue;
    }
    r = pending_->front();
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
