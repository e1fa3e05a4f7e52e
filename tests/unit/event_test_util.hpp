#pragma once
// Helpers for tests that read event files as a user's data: the events the pipeline cuts.
#include <vector>

#include "core/pipeline/event_csv.hpp"
#include "core/pipeline/pipeline.hpp"

namespace brakefit::test {

/// The events the pipeline (no fits) cuts from a parsed event CSV; as_file: the file's last row
/// ends its event (finish_file), else the stream just stops (finish).
inline std::vector<pipeline::Event> detect(const pipeline::EventCsv& csv, bool as_file) {
  pipeline::PipelineOptions o;
  o.fit = false;
  pipeline::Pipeline p(csv.calibration, o, nullptr);
  for (const auto& s : csv.samples) p.feed(s);
  as_file ? p.finish_file() : p.finish();
  std::vector<pipeline::Event> out;
  for (auto& e : p.events()) out.push_back(e.event);
  return out;
}

}  // namespace brakefit::test
