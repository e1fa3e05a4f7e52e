#pragma once
// Writes an MF 6.1 tyre property file (.tir, the TNO/ADAMS format MFeval, TyreDyn, Simscape, Adams
// and CarMaker read): [MDI_HEADER], [UNITS], [MODEL] FITTYP = 61, [DIMENSION],
// [OPERATING_CONDITIONS], [VERTICAL], the slip and load ranges measured, [SCALING_COEFFICIENTS] and
// [LONGITUDINAL_COEFFICIENTS]. Every coefficient says on its line whether it was fitted (with its
// standard error) or held (with why); the header carries the provenance.
#include <optional>
#include <string>
#include <vector>

#include "core/tyre/mf61_fit.hpp"
#include "core/tyre/scaling.hpp"

namespace brakefit::tyre {

struct TirProvenance {
  std::string brakefit_version;
  std::string model_hash;
  std::string created;            ///< e.g. an ISO date; empty: not written
  std::vector<std::string> runs;  ///< the inputs, as given
  double rolling_radius_m = NAN;  ///< the radius the slips were computed with
  std::string tyre_name;          ///< free text for the header
};

/// The file's text. With `scalings`, [SCALING_COEFFICIENTS] carries them (a rig relative to the
/// tyre's own file) instead of 1.
std::string format_tir(const Mf61FitResult& fit, const TirProvenance& prov,
                       const std::optional<ScalingFit>& scalings = std::nullopt);

}  // namespace brakefit::tyre
