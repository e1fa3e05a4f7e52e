#pragma once
// The labelled curve database the SOM and MLP learn from: N Magic Formula curves drawn from
// parameter ranges of tyre families, sampled on the fixed slip grid. Deterministic from a seed.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "core/magic_formula.hpp"

namespace brakefit {

struct ParamRange {
  double lo = 0.0;
  double hi = 0.0;
  bool contains(double v, double tol = 1e-12) const { return v >= lo - tol && v <= hi + tol; }
};

struct TyreFamily {
  std::string name;
  double weight = 1.0;  ///< relative share of the database
  ParamRange B;         ///< per unit slip ratio
  ParamRange C;
  ParamRange D_n;
  ParamRange E;
};

struct DatabaseSettings {
  std::string preset = "default";
  std::uint64_t seed = 20261121;
  std::size_t n_curves = 2000;
  std::vector<TyreFamily> families;
};

/// "default": realistic passenger-car and truck tyres (physics.md §1). "paper": ranges around the
/// paper's Table 3-4 values (slip in percent there: B 0.25-0.6 per % = 25-60 per ratio, E 30-50).
/// Throws InputError for an unknown name.
DatabaseSettings database_preset(const std::string& name);

/// Draws one parameter set from the settings' families.
class Rng;
MfParams draw_params(const DatabaseSettings& s, Rng& rng, std::size_t* family_index = nullptr);

struct CurveDatabase {
  std::vector<double> grid;         ///< slip ratios
  Eigen::MatrixXd forces_n;         ///< N x G, row i = curve i on the grid
  std::vector<MfParams> labels;     ///< the parameters of each curve
  std::vector<std::size_t> family;  ///< index into settings.families
};

CurveDatabase generate_database(const DatabaseSettings& s, const std::vector<double>& grid);

}  // namespace brakefit
