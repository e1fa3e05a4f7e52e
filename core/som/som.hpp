#pragma once
// Self-organizing map (Kohonen; definitions as in SOM Toolbox 2): random or linear (PCA)
// initialisation, batch or sequential training in a rough and a fine phase, gaussian / cutgauss /
// ep / bubble neighbourhoods, BMU search (optionally masked and scale-invariant), qe, te, U-matrix.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/som/lattice.hpp"

namespace brakefit::som {

enum class Neighbourhood { Gaussian, CutGauss, Ep, Bubble };
enum class Init { Random, Linear };
enum class Algorithm { Batch, Sequential };

const char* to_string(Neighbourhood n);
const char* to_string(Init i);
const char* to_string(Algorithm a);
/// Parse helpers; return false for an unknown name.
bool parse(const std::string& s, Neighbourhood& out);
bool parse(const std::string& s, Init& out);
bool parse(const std::string& s, Algorithm& out);

/// Neighbourhood weight at lattice distance d for radius r.
double neighbourhood_weight(Neighbourhood n, double d, double r);
/// Radius in epoch t (1-based) of a phase of T epochs: r_fin + (r_ini - r_fin)(T - t)/(T - 1).
double radius_at(double r_ini, double r_fin, std::size_t t, std::size_t T);

struct Phase {
  std::size_t epochs = 0;
  double radius_ini = 0.0;  ///< <= 0: Toolbox default for the phase
  double radius_fin = 0.0;
  double alpha_ini = 0.0;  ///< sequential only
};

struct SomSettings {
  std::size_t rows = 10;
  std::size_t cols = 10;
  Init init = Init::Random;
  Algorithm algorithm = Algorithm::Batch;
  Neighbourhood neighbourhood = Neighbourhood::Gaussian;
  Phase rough{1000, 0.0, 0.0, 0.5};
  Phase fine{500, 0.0, 0.0, 0.05};
  std::uint64_t seed = 1;
};

/// Fills in the Toolbox default radii: rough r_ini = max(1, ceil(maxside/4)) (random init) or
/// max(1, ceil(maxside/8)) (linear init), rough r_fin = max(1, r_ini/4); fine r_ini = rough r_fin,
/// fine r_fin = 1.
SomSettings with_default_radii(SomSettings s);

using Progress = std::function<void(const char* phase, std::size_t epoch, std::size_t epochs)>;

class Som {
 public:
  Som() = default;
  Som(HexLattice lattice, Eigen::MatrixXd codebook);

  /// Initialises the codebook from the data (rows = samples) as the settings say.
  static Som initialise(const SomSettings& s, const Eigen::MatrixXd& data);
  void train(const SomSettings& s, const Eigen::MatrixXd& data, const Progress& progress = {});
  /// One batch epoch with radius r: m_i = sum_j h(i,c(j)) x_j / sum_j h(i,c(j)); units with zero
  /// total weight are left unchanged.
  void batch_epoch(const Eigen::MatrixXd& data, const Eigen::VectorXd& data_sq, Neighbourhood n,
                   double r);

  const HexLattice& lattice() const { return lattice_; }
  const Eigen::MatrixXd& codebook() const { return codebook_; }
  std::size_t units() const { return lattice_.size(); }
  std::size_t dim() const { return static_cast<std::size_t>(codebook_.cols()); }

  /// BMU of a complete vector (Euclidean).
  std::size_t bmu(const Eigen::Ref<const Eigen::RowVectorXd>& x) const;
  /// BMUs of all rows.
  std::vector<std::size_t> bmus(const Eigen::MatrixXd& data) const;
  /// Best and second-best units of a vector.
  std::pair<std::size_t, std::size_t> two_bmus(const Eigen::Ref<const Eigen::RowVectorXd>& x) const;

  struct Match {
    std::size_t unit = 0;
    double distance_sq = 0.0;
    double scale = 1.0;  ///< optimal scale (scale-invariant search), else 1
  };
  /// BMU over the masked components only; with scale_invariant the distance is
  /// min_s ||x - s*m||^2 (shape matching). Only units with allowed[u] (if given) are considered.
  Match bmu_masked(const std::vector<double>& x, const std::vector<bool>& mask,
                   bool scale_invariant, const std::vector<bool>* allowed = nullptr) const;

  double quantization_error(const Eigen::MatrixXd& data) const;  ///< qe: mean distance to BMU
  double topographic_error(
      const Eigen::MatrixXd& data) const;  ///< te: share of non-adjacent 1st/2nd BMUs
  Eigen::VectorXd umatrix() const;         ///< per unit: mean distance to its neighbours' weights

 private:
  Eigen::MatrixXd distances_sq(const Eigen::MatrixXd& data, const Eigen::VectorXd& data_sq) const;
  HexLattice lattice_;
  Eigen::MatrixXd codebook_;  ///< units x dim
};

}  // namespace brakefit::som
