// candump -L text: parse (strict and lenient), every frame formats back to a line that parses to
// the same frame, and the frames run through the pipeline (samples, events; LM fits).
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "core/can/candump.hpp"
#include "core/curve.hpp"
#include "core/pipeline/pipeline.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace brakefit;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    can::parse_candump_text(text, "fuzz.log", false);
  } catch (const InputError&) {
  }
  const can::CandumpText t = can::parse_candump_text(text, "fuzz.log", true);
  pipeline::Pipeline p(pipeline::Calibration{}, pipeline::PipelineOptions{}, nullptr);
  std::size_t n = 0;
  for (const auto& f : t.frames) {
    const auto again = can::parse_candump_line(can::format_candump_line(f));
    if (!again || again->t_us != f.t_us || again->frame.id != f.frame.id ||
        again->frame.len != f.frame.len)
      std::abort();              // format and parse disagree
    if (++n <= 1500) p.feed(f);  // bounded work per input
  }
  p.finish();
  return 0;
}
