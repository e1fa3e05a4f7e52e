#include "daemon/daemon.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>
#include <systemd/sd-daemon.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>
#include <thread>

#include <unistd.h>

#include "brakefit/version.hpp"

#include "core/event_json.hpp"
#include "core/model_io.hpp"
#include "drivers/socketcan.hpp"

namespace brakefit::daemon {

namespace {

std::int64_t unix_now() {
  return static_cast<std::int64_t>(std::time(nullptr));
}

int channel_of(std::uint32_t id) {
  switch (id) {
    case can::kIdRollerEncoder:
    case can::kIdFifthWheelEncoder:
      return 0;
    case can::kIdWheelEncoder:
      return 1;
    case can::kIdBrakePressure:
      return 2;
    default:
      return -1;
  }
}

void set_log_level(const std::string& l) {
  spdlog::set_level(spdlog::level::from_str(l));
}

/// A replayed log's own calibration (<stem>.bench.toml beside it) replaces [bench]: the log was
/// recorded on that bench. Logged either way, so nobody wonders which gain made the forces.
void use_replay_calibration(Config& c, const std::string& config_path) {
  if (c.kind != SourceKind::Replay) return;
  const std::string bench = pipeline::recording_stem(c.replay_file) + ".bench.toml";
  if (::access(bench.c_str(), R_OK) != 0) {
    spdlog::info("replay: calibration from [bench] in {} (no {} beside the log)", config_path,
                 bench);
    return;
  }
  try {
    c.calibration = pipeline::parse_calibration(read_text_file(bench), bench);
  } catch (const std::exception& e) {
    throw DaemonError(kExitConfig, fmt::format("source: {}", e.what()));
  }
  spdlog::info("replay: calibration from {} (the log's own; [bench] in {} not used)", bench,
               config_path);
}

std::vector<std::uint32_t> layout_ids() {
  std::vector<std::uint32_t> ids;
  for (const auto& m : can::layout()) ids.push_back(m.id);
  return ids;
}

}  // namespace

Daemon::Daemon(std::string config_path, Config cfg, Signals& sig)
    : config_path_(std::move(config_path)), cfg_(std::move(cfg)), sig_(sig) {
  set_log_level(cfg_.log_level);
  lock_ = std::make_unique<InstanceLock>(cfg_.store.path);
  model_ = load_model(cfg_.model_path);
  try {
    store_ = std::make_unique<EventStore>(cfg_.store, false, kStoreBusyTimeoutMs);
  } catch (const std::exception& e) {
    throw DaemonError(kExitCantCreate, e.what());
  }
  try {
    server_ = std::make_unique<ModbusServer>(cfg_.modbus_tcp);
  } catch (const std::exception& e) {
    throw DaemonError(kExitOsErr, e.what());
  }
  try {
    switch (cfg_.kind) {
      case SourceKind::Replay:
        if (::access(cfg_.replay_file.c_str(), R_OK) != 0)
          throw DaemonError(kExitUnavailable, fmt::format("source: {}: cannot open: {}",
                                                          cfg_.replay_file, std::strerror(errno)));
        try {  // there and readable: what is wrong now is its content (65, naming the line)
          source_ = std::make_unique<drivers::ReplaySource>(cfg_.replay_file, cfg_.replay_speed,
                                                            cfg_.replay_loop);
        } catch (const InputError& e) {
          throw DaemonError(kExitDataError, fmt::format("source: {}", e.what()));
        }
        break;
      case SourceKind::SocketCan:
        source_ = std::make_unique<drivers::SocketCanSource>(
            drivers::CanSocket::open(cfg_.can_interface, layout_ids()), cfg_.can_interface);
        break;
      case SourceKind::Gpio:
        source_ = std::make_unique<drivers::LocalLiveSource>(cfg_.gpio, cfg_.rtu,
                                                             drivers::open_edge_source);
        break;
    }
  } catch (const InputError& e) {
    throw DaemonError(kExitUnavailable, fmt::format("source: {}", e.what()));
  } catch (const drivers::SourceError& e) {
    throw DaemonError(kExitUnavailable, e.what());
  }
  if (cfg_.record.enabled && cfg_.kind != SourceKind::Replay) {
    try {
      recorder_ = std::make_unique<drivers::CandumpRecorder>(
          cfg_.record.dir, static_cast<std::uint64_t>(cfg_.record.max_mb * 1048576.0),
          cfg_.record.max_age_s, cfg_.record.keep_files);
    } catch (const std::exception& e) {
      throw DaemonError(kExitCantCreate, e.what());
    }
  }
  use_replay_calibration(cfg_, config_path_);
  pipeline_ = std::make_unique<pipeline::Pipeline>(cfg_.calibration, cfg_.pipeline, model_.get());
  pending_ = std::make_unique<PendingEvents>(
      cfg_.store.spill_dir.empty() ? cfg_.store.path + ".spill" : cfg_.store.spill_dir,
      static_cast<std::size_t>(cfg_.store.hold_in_memory),
      static_cast<std::size_t>(cfg_.store.max_held));
  try {
    pending_->check_writable();
  } catch (const std::exception& e) {
    throw DaemonError(kExitCantCreate,
                      fmt::format("{} (the journal: without it a kill loses the event being "
                                  "stored)",
                                  e.what()));
  }
  if (const auto n = pending_->adopt_spilled())
    spdlog::warn("{} event(s) spilled by an earlier run wait in {}: committing them first", n,
                 pending_->dir());
  restore_last_event();
  server_->start();
  spdlog::info("brakefitd: source {}, Modbus TCP on {}:{} ({}), store {}", source_->describe(),
               cfg_.modbus_tcp.address, server_->port(),
               cfg_.modbus_tcp.writable ? "commands writable" : "read-only", cfg_.store.path);
}

Daemon::~Daemon() {
  if (server_) server_->stop();
}

std::unique_ptr<const Model> Daemon::load_model(const std::string& path) {
  if (path.empty()) {
    spdlog::warn("no model configured: only the lm method runs");
    return nullptr;
  }
  try {
    return std::make_unique<const Model>(deserialize_model(read_text_file(path), path));
  } catch (const std::exception& e) {
    throw DaemonError(kExitConfig, fmt::format("{} (key 'daemon.model')", e.what()));
  }
}

void Daemon::reload() {
  sd_notify(0, "RELOADING=1");
  spdlog::info("reloading {}", config_path_);
  try {
    Config next = load_config(config_path_);
    if (next.kind != cfg_.kind || next.replay_file != cfg_.replay_file ||
        next.can_interface != cfg_.can_interface || next.modbus_tcp.port != cfg_.modbus_tcp.port ||
        next.modbus_tcp.address != cfg_.modbus_tcp.address || next.store.path != cfg_.store.path ||
        next.store.spill_dir != cfg_.store.spill_dir)
      spdlog::warn(
          "reload: changes to [source], the Modbus address/port or the store or spill paths need a "
          "restart");
    next.kind = cfg_.kind;
    next.replay_file = cfg_.replay_file;
    next.can_interface = cfg_.can_interface;
    next.modbus_tcp.port = cfg_.modbus_tcp.port;
    next.modbus_tcp.address = cfg_.modbus_tcp.address;
    next.store.path = cfg_.store.path;
    next.store.spill_dir = cfg_.store.spill_dir;
    // Everything new is built aside; nothing running is touched until all of it has loaded.
    // The model is re-read even when its path is unchanged: a retrained file may sit there.
    use_replay_calibration(next, config_path_);
    auto next_model = load_model(next.model_path);
    auto next_pipeline =
        std::make_unique<pipeline::Pipeline>(next.calibration, next.pipeline, next_model.get());
    // Swap (nothing below throws): the old pipeline goes before the model it points into.
    pipeline_ = std::move(next_pipeline);
    model_ = std::move(next_model);
    cfg_ = std::move(next);
    set_log_level(cfg_.log_level);
    server_->set_write_policy(cfg_.modbus_tcp.writable, cfg_.modbus_tcp.write_allow);
    spdlog::info("reloaded {}{}", config_path_,
                 model_ ? fmt::format(" (model {})", model_->hash) : "");
  } catch (const std::exception& e) {
    spdlog::error("reload failed, keeping the running configuration: {}", e.what());
  }
  last_status_.clear();
  sd_notify(0, "READY=1");
  notify_status();
}

int Daemon::run() {
  start_ = Clock::now();
  commit_pending(start_, true);  // events spilled by an earlier run go first
  std::uint64_t watchdog_us = 0;
  if (sd_watchdog_enabled(0, &watchdog_us) <= 0) watchdog_us = 0;
  sd_notify(0, "READY=1");
  notify_status();
  const bool paced = cfg_.kind != SourceKind::Replay || cfg_.replay_speed > 0;
  auto last_post = Clock::time_point{}, last_ping = Clock::now(), last_notify = Clock::now(),
       last_retention = Clock::time_point{};
  while (!sig_.stop) {
    if (sig_.reload.exchange(false)) reload_pending_ = true;
    if (reload_pending_ && !pipeline_->event_active()) {
      reload_pending_ = false;
      reload();
    }
    bool polled_empty = false;
    if (auto f = source_->next(10)) {
      const auto now = Clock::now();
      idle_since_.reset();
      if (recorder_ && !recorder_->write(*f)) recorder_error_ = true;
      const int ch = channel_of(f->frame.id);
      if (ch >= 0) {
        seen_[static_cast<std::size_t>(ch)] = now;
        stamp_us_[static_cast<std::size_t>(ch)] = f->t_us;
      }
      newest_stamp_us_ = std::max(newest_stamp_us_, f->t_us);
      pipeline_->feed(*f);
      publish_finished(now);
    } else {
      polled_empty = true;
      if (!idle_since_) idle_since_ = Clock::now();
      if (source_->finished() && !source_finished_) {
        source_finished_ = true;
        pipeline_->finish();
        publish_finished(Clock::now());
        spdlog::info("replay finished: {} events", events_finished_);
        if (cfg_.exit_at_end) break;
      }
    }
    const auto now = Clock::now();
    commit_pending(now, false);
    if (paced && pipeline_->event_active()) {
      if (const auto ch = silent_channel(now, polled_empty)) {
        spdlog::warn("sensor timeout during an event ({} silent): event aborted",
                     *ch == 0   ? "reference encoder"
                     : *ch == 1 ? "wheel encoder"
                     : *ch == 2 ? "pressure"
                                : "every sensor");
        pipeline_->abort("sensor_timeout");
        publish_finished(now);
      }
    }
    for (const auto& cmd : server_->take_commands()) {
      if (cmd.vehicle_id) {
        vehicle_id_ = *cmd.vehicle_id;
        spdlog::info("vehicle id set to '{}'", vehicle_id_);
      }
      if (cmd.command == kCmdArm) {
        spdlog::info("command: arm");
        pipeline_->arm();
      } else if (cmd.command == kCmdAbort) {
        spdlog::info("command: abort");
        pipeline_->abort("operator_abort");
        publish_finished(now);
      } else if (cmd.command != kCmdNone) {
        spdlog::warn("unknown command {}", cmd.command);
      }
    }
    if (now - last_post > std::chrono::milliseconds(50)) {
      post_status(now);
      last_post = now;
    }
    if (now - last_notify > std::chrono::seconds(1)) {
      notify_status();
      if (recorder_) recorder_->flush();
      last_notify = now;
    }
    if (now - last_retention > std::chrono::minutes(10)) {
      const int n = store_->apply_retention(unix_now());
      if (n > 0) spdlog::info("retention: {} old events deleted", n);
      last_retention = now;
    }
    // The loop has serviced its input (or its timeout): the watchdog may be fed.
    if (watchdog_us && now - last_ping > std::chrono::microseconds(watchdog_us / 4)) {
      sd_notify(0, "WATCHDOG=1");
      last_ping = now;
    }
  }
  sd_notify(0, "STOPPING=1");
  if (pipeline_->event_active()) {
    pipeline_->abort("shutdown");
    publish_finished(Clock::now());
  }
  commit_pending(Clock::now(), true);
  const int code = stop_pending();
  if (recorder_) recorder_->flush();
  post_status(Clock::now());
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  server_->stop();
  auto lat = server_->publish_latencies_us();
  std::sort(lat.begin(), lat.end());
  auto pct = [&](double q) {
    return lat.empty() ? NAN
                       : lat[static_cast<std::size_t>(q * static_cast<double>(lat.size() - 1))];
  };
  spdlog::info("stopped: {} events ({} flagged), publish latency p50 {:.0f} us p99 {:.0f} us",
               events_finished_, events_flagged_, pct(0.5), pct(0.99));
  if (!cfg_.stats_file.empty()) {
    nlohmann::ordered_json j;
    j["schema"] = "brakefit.daemon_stats/1";
    j["version"] = kVersion;
    j["events"] = events_finished_;
    j["events_flagged"] = events_flagged_;
    j["frames"] = source_->counters().frames.load();
    j["publish_latency_us"] = {{"n", lat.size()},
                               {"p50", num(pct(0.5))},
                               {"p99", num(pct(0.99))},
                               {"max", num(lat.empty() ? NAN : lat.back())}};
    const auto& s = server_->stats();
    j["modbus"] = {{"requests", s.requests.load()},
                   {"exceptions", s.exceptions.load()},
                   {"malformed", s.malformed.load()},
                   {"rejected", s.rejected.load()},
                   {"timeouts", s.timeouts.load()}};
    j["events_lost"] = pending_->lost();
    j["events_waiting"] = pending_->size();
    std::ofstream(cfg_.stats_file) << j.dump(2) << "\n";
  }
  return code;
}

int Daemon::stop_pending() {
  if (pending_->size() == 0 && pending_->lost() == 0) return 0;
  const std::size_t failed = pending_->spill_all();
  if (pending_->size() > 0)
    spdlog::warn(
        "stopping with {} event(s) not stored: they wait in {}, and the next start "
        "commits them",
        pending_->size(), pending_->dir());
  if (pending_->lost() == 0) return 0;
  spdlog::error(
      "{} finished event(s) lost in this run ({} at this stop): neither the store {} nor "
      "the spill directory {} could take them",
      pending_->lost(), failed, cfg_.store.path, pending_->dir());
  return kExitCantCreate;
}

std::optional<int> Daemon::silent_channel(Clock::time_point now, bool polled_empty) const {
  // In the data's own time: a process stalled (SIGSTOP, a swap storm) finds its frames queued
  // when it runs again and ends no event for its own pause.
  const auto timeout_us = static_cast<std::int64_t>(cfg_.sensor_timeout_s * 1e6);
  for (int ch = 0; ch < 3; ++ch) {
    const auto& last = stamp_us_[static_cast<std::size_t>(ch)];
    if (last && newest_stamp_us_ - *last > timeout_us) return ch;
  }
  // Nothing arrives at all: judged right after a poll found nothing, so a pause of the process
  // itself (its frames then wait in the queue, and the poll after it finds them) is not silence.
  const double wall_timeout_s =
      cfg_.sensor_timeout_s /
      (cfg_.kind == SourceKind::Replay ? std::max(1.0, cfg_.replay_speed) : 1.0);
  if (polled_empty && idle_since_ &&
      std::chrono::duration<double>(now - *idle_since_).count() > wall_timeout_s)
    return 3;
  return std::nullopt;
}

}  // namespace brakefit::daemon
