// Model files: as given (the checksum refuses nearly all), and re-signed so the fuzzer reaches
// the structural checks behind the checksum; a model that loads identifies a curve with every
// method (where an empty SOM once read out of bounds).
#include <cstdint>
#include <string_view>

#include "core/curve.hpp"
#include "core/identify.hpp"
#include "core/magic_formula.hpp"
#include "core/model_io.hpp"

namespace {

void load_and_use(std::string_view text) {
  using namespace brakefit;
  const Model m = deserialize_model(text, "fuzz.json");
  const Curve c = sample_curve({12, 1.6, 4000, 0.3, 0, 0}, even_slips(40, 0.3));
  for (Method meth : {Method::Som, Method::Mlp, Method::Hybrid}) run_method(meth, &m, c);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace brakefit;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    load_and_use(text);
  } catch (const InputError&) {
  }
  try {
    load_and_use(resign_model_text(text));
  } catch (const InputError&) {
  }
  return 0;
}
