// DBC: parse; every signal of what parses is decoded from and encoded into a full frame.
#include <cstdint>
#include <string_view>

#include "core/can/dbc.hpp"
#include "core/curve.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace brakefit;
  try {
    const auto msgs =
        can::parse_dbc(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.dbc");
    can::Frame f;
    f.len = 64;
    f.data.fill(0xA5);
    for (const auto& m : msgs)
      for (const auto& s : m.signals) {
        const double v = can::decode_signal(f, s);
        can::encode_signal(f, s, v);
      }
  } catch (const InputError&) {
  }
  return 0;
}
