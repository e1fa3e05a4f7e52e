#pragma once
// Training configuration: curve database, SOM and MLP settings. Parsed from TOML text with strict
// validation (unknown keys, wrong types and out-of-range values name the key), and rendered back
// to TOML so a model file can record exactly how it was trained.
#include <string>
#include <string_view>

#include "core/curve_db.hpp"
#include "core/mlp/mlp.hpp"
#include "core/som/som.hpp"

namespace brakefit {

/// What the SOM is trained on: peak-normalised shapes (D then comes from a linear least-squares
/// scale on the measured points) or raw force curves (D is averaged from the labels as well).
enum class SomInput { Shape, Raw };
const char* to_string(SomInput s);

struct TrainConfig {
  DatabaseSettings database = database_preset("default");
  som::SomSettings som;
  SomInput som_input = SomInput::Shape;
  mlp::TrainSettings mlp;
  double mlp_truncate_fraction = 0.7;    ///< share of MLP training curves cut short (roller tests)
  double mlp_truncate_min_ratio = 0.04;  ///< cut slip range for those curves: to the grid's end,
  double mlp_truncate_max_ratio = 1.0;   ///< or a curve ending past the longest cut is new to it
  std::size_t mlp_ensemble = 5;          ///< networks in the MLP, seeds mlp.seed, mlp.seed + 1, ...
};

/// Throws InputError "SOURCE: key 'a.b': ..." or "SOURCE:LINE:COL: ..." for TOML syntax errors.
TrainConfig parse_train_config(std::string_view toml_text, const std::string& source);
std::string format_train_config(const TrainConfig& c);

}  // namespace brakefit
