#pragma once
// Loading a run for replay, export, compare and gap: a candump log (with its calibration from
// --bench or <stem>.bench.toml beside it) or an event CSV (calibration in its header), pushed
// through the core pipeline.
#include <optional>
#include <string>
#include <vector>

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
};

Run process_run(const std::string& path, const RunOptions& o, const Model* model);

}  // namespace brakefit::cli
