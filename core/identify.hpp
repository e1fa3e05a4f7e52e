#pragma once
// A trained model (SOM + its unit labels + MLP, with the settings they were trained from) and the
// four identification methods: som (the paper's: average of the parameters labelled on the BMU),
// mlp, lm (classic least squares from a fixed start) and hybrid (LM seeded by SOM and MLP).
#include <optional>
#include <string>
#include <vector>

#include "core/curve.hpp"
#include "core/fit/mf_fit.hpp"
#include "core/metrics.hpp"
#include "core/mlp/mlp.hpp"
#include "core/som/som.hpp"
#include "core/train_config.hpp"

namespace brakefit {

struct Model {
  TrainConfig config;
  std::vector<double> grid;  ///< slip ratios of the SOM / MLP input
  som::Som som;
  std::vector<std::size_t> unit_hits;  ///< database curves mapped to each unit
  std::vector<MfParams> unit_labels;   ///< mean parameters of those curves (valid where hits > 0)
  double som_qe = 0.0;
  double som_te = 0.0;
  /// The MLP: an ensemble of networks on one input and output scaling, trained alike from their
  /// own seeds; its estimate is their mean (one network's estimate varies with its seed by more
  /// than the ensemble's does).
  std::vector<mlp::Network> mlp;
  mlp::Scaler mlp_in;
  mlp::Scaler mlp_out;
  std::vector<mlp::TrainReport> mlp_report;  ///< one per network
  std::string hash;  ///< "sha256:..." of the serialised model (set by save/load)
};

enum class Method { Som, Mlp, Lm, Hybrid };
const char* to_string(Method m);
bool parse(const std::string& s, Method& out);

/// What a result describes: the instrument's raw force against its slip, or the tyre's curve with
/// the bench's measured effects undone (a bench measurement model, core/gap/bench_model.hpp).
enum class Basis { Instrument, Tyre };
const char* to_string(Basis b);

struct MethodResult {
  Method method = Method::Lm;
  Basis basis = Basis::Instrument;
  MfParams params;
  FitMetrics metrics;
  bool peak_reached = false;
  std::optional<std::array<double, kMfParamCount>> stderr_;  ///< only for least-squares methods
  std::optional<std::size_t> bmu;                            ///< SOM unit used (som, hybrid)
  std::vector<std::string> at_bound;  ///< least squares: parameters that ended on a bound
  std::array<std::string, kMfParamCount> stderr_null_reason{};  ///< why a stderr is null
  int iterations = 0;
  bool converged = true;
  /// Why these parameters cannot be a tyre's curve (empty: nothing found); see implausible_curve.
  std::vector<std::string> implausible;
};

/// The limits of what a tyre's longitudinal curve does: its peak friction (the curve's maximum over
/// slip 0-1 divided by the wheel load) and its shape factor C.
struct TyreLimits {
  double min_peak_friction = 0.05;  ///< glare ice
  double max_peak_friction = 1.6;   ///< soft racing rubber on a dry, clean surface
  double min_C = 1.0;               ///< below 1 the curve has no peak: not a tyre's shape
  double max_C = 2.5;
};
/// The reasons params cannot describe a tyre (empty when none); the peak friction is judged only
/// with a finite wheel_load_n.
std::vector<std::string> implausible_curve(const MfParams& p, double wheel_load_n,
                                           const TyreLimits& l = {});

/// Adds implausible_curve's reasons to those the method itself gave (an MLP extrapolating).
void flag_implausible(MethodResult& r, double wheel_load_n);

/// Why the MLP's estimate for this curve is an extrapolation (empty when it is not): the curve
/// ends at a slip short of any the network was trained on (training cuts curves no shorter than
/// the model's truncate range allows). Such an estimate is flagged with the implausible ones.
std::vector<std::string> mlp_outside_training(const Model& m, const Curve& c);

/// Why the MLP's estimate itself lies outside what it was trained on (empty when it does not): a
/// B, C or E past the range the training database's families span, by more than
/// kMlpOutputMargin of that range's width.
std::vector<std::string> mlp_estimate_outside_training(const Model& m, const MfParams& p);
/// The network's targets span the families' ranges; past them it guesses. On generator C's
/// ground runs (curves unlike its training) such estimates were 21x the least-squares fit's RMS
/// error (median), those inside 1.2x; a tenth of the width leaves the rounding of a good estimate
/// at a range's edge alone.
inline constexpr double kMlpOutputMargin = 0.1;

/// Peak-normalised shape on the grid (divided by max |value| over the valid points).
std::vector<double> normalise_shape(const GridCurve& g);
/// MLP input features: the normalised shape (0 where masked) and the last valid slip.
Eigen::RowVectorXd mlp_features(const GridCurve& g, const std::vector<double>& grid);
/// Least-squares D for fixed B, C, E: argmin_D sum (f - D s(x))^2, s = formula with D = 1.
double fit_scale_D(const Curve& c, double B, double C, double E);

struct SomEstimate {
  MfParams params;
  std::size_t bmu = 0;
  bool fallback = false;  ///< the BMU held no labels: the nearest labelled unit was used
};
SomEstimate identify_som(const Model& m, const Curve& c);
MfParams identify_mlp(const Model& m, const Curve& c);

/// Least-squares options for a model: the default bounds, widened to cover the model's database
/// ranges (the paper preset has E up to 50, beyond the usual E <= 1).
fit::MfFitOptions fit_options_for(const Model* m);

/// Runs one method on a curve (som/mlp/hybrid need a trained model).
/// parallel: the hybrid's two LM starts run concurrently (same result).
MethodResult run_method(Method method, const Model* model, const Curve& c,
                        const fit::MfFitOptions& options = {}, bool parallel = false);

}  // namespace brakefit
