#include "cli/tyre_load_laws.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "cli/io.hpp"
#include "core/curve.hpp"
#include "core/gap/gap.hpp"
#include "core/tyre/tir_numbers.hpp"
#include "sim/second/tir.hpp"

namespace brakefit::cli {

tyre::LoadLaws tyre_load_laws_from(const std::string& path, const std::vector<gap::Run>& runs) {
  const double fz_n = gap::median_wheel_load_n(runs);
  if (!(fz_n > 0))
    throw ExitError(kExitDataError,
                    fmt::format("gap: --tir {}: the runs carry no wheel load (the bench "
                                "calibration's wheel_load_n), at which the file's laws are read",
                                path));
  try {
    const tyre::Mf61Tyre t =
        tyre::tyre_from_tir(sim2::parse_tir(read_file(path), path).numbers, path);
    const tyre::LoadLaws laws = tyre::load_laws_at(t, fz_n);
    spdlog::info(
        "gap: {} at the runs' {:.0f} N ({:.2f} x its FNOMIN x LFZO): d ln D / d ln Fz {:.3f}, the "
        "slip stiffness's load ratio {:.3f}, E by {:.3f} per unit of the peak's change",
        path, fz_n, fz_n / (t.ref.fnomin_n * t.ref.lfzo), laws.peak_exponent, laws.kx_over_peak,
        laws.e_per_peak_scale);
    return laws;
  } catch (const InputError& e) {
    throw ExitError(kExitDataError, fmt::format("gap: --tir: {}", e.what()));
  }
}

}  // namespace brakefit::cli
