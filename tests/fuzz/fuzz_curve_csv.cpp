// Curve CSV (slip, force): parse; what parses is fitted by LM (bounded work per input).
#include <cstdint>
#include <string_view>

#include "core/curve.hpp"
#include "core/curve_csv.hpp"
#include "core/identify.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace brakefit;
  try {
    const auto c =
        parse_curve_csv(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.csv");
    if (c.curve.size() <= 200) run_method(Method::Lm, nullptr, c.curve);
  } catch (const InputError&) {
  }
  return 0;
}
