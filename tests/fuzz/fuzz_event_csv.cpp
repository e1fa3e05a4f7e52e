// Event CSV (one brake event with its bench metadata): parse; what parses is run through the
// pipeline as `brakefit replay` runs an event file.
#include <cstdint>
#include <string_view>

#include "core/curve.hpp"
#include "core/pipeline/event_csv.hpp"
#include "core/pipeline/pipeline.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace brakefit;
  try {
    const auto e = pipeline::parse_event_csv(
        std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.csv");
    if (e.samples.size() > 5000) return 0;
    pipeline::Pipeline p(e.calibration, pipeline::PipelineOptions{}, nullptr);
    for (const auto& s : e.samples) p.feed(s);
    p.finish_file();
  } catch (const InputError&) {
  }
  return 0;
}
