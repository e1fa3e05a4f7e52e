#pragma once
// Loading a run for replay, export, compare and gap: a candump log (with its calibration from
// --bench or <stem>.bench.toml beside it) or an event CSV (calibration in its header), pushed
// through the core pipeline.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/gap/bench_model.hpp"
#include "core/pipeline/pipeline.hpp"

namespace brakefit::cli {

struct RunOptions {
  std::string bench_file;  ///< overrides <stem>.bench.toml
  bool lenient = false;    ///< skip (and count) malformed log lines
  pipeline::PipelineOptions pipeline;
};

struct Run {
  std::string path;
  pipeline::Calibration calibration;
  std::vector<pipeline::EventResult> events;
  pipeline::SampleStats stats;
  std::size_t malformed_lines = 0;
  std::size_t ignored_lines = 0;
  std::size_t truncated = 0;  ///< a cut log: last line without newline + frames short of their DLC
};

Run process_run(const std::string& path, const RunOptions& o, const Model* model);

/// Reads a bench measurement model (exit 66 when it cannot be read, 65 naming the file and key
/// when malformed).
std::shared_ptr<const gap::BenchModel> load_bench_model(const std::string& path);
/// The effects a bench model holds, e.g. "relaxation_length sigma_m 0.209, wheel_inertia ...".
std::string held_effects(const gap::BenchModel& bm);

/// The text report of one event: what it was, then one line per method (B, C, D, E, MAPE, RMSE
/// and its notes), then the same on the tyre's basis when a bench model was applied.
void print_event(const Run& run, const pipeline::EventResult& e,
                 const gap::BenchModel* bench_model);

/// An event a command did not use, and why: every command names them on stderr and in its JSON
/// ("left_out"), so nothing is dropped silently.
struct LeftOut {
  std::string file;
  int event_id = 0;
  std::string reason;
};
/// Records (and logs as a warning) that this event of this run was left out.
void leave_out(std::vector<LeftOut>& out, const Run& run, const pipeline::Event& e,
               const std::string& reason);
/// Records (and logs) that a run held no brake event at all (event_id 0 in the JSON).
void leave_out_if_empty(std::vector<LeftOut>& out, const Run& run);
/// The reason a flagged event is not fitted: its flags and how it ended.
std::string flagged_reason(const pipeline::Event& e);
nlohmann::ordered_json left_out_json(const std::vector<LeftOut>& left_out);

}  // namespace brakefit::cli
