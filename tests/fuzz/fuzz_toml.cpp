// The TOML files an operator writes: the first byte picks the parser (bench calibration, daemon
// configuration, training configuration), the rest is the file.
#include <cstdint>
#include <string_view>

#include "core/curve.hpp"
#include "core/pipeline/calibration.hpp"
#include "core/train_config.hpp"
#include "daemon/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace brakefit;
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    switch (data[0] % 3) {
      case 0:
        pipeline::parse_calibration(text, "fuzz.bench.toml");
        break;
      case 1:
        daemon::parse_config(text, "fuzz.toml");
        break;
      default:
        parse_train_config(text, "fuzz.train.toml");
    }
  } catch (const InputError&) {
  }
  return 0;
}
