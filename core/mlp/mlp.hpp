#pragma once
// Multilayer perceptron for curve -> parameter regression: tanh hidden layers, linear output,
// mean squared error. Trainers (paper Table 1): resilient backpropagation (iRprop-, default),
// gradient descent with momentum, and Levenberg-Marquardt (for small networks). Early stopping on a
// validation split keeps the weights of the best validation epoch.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace brakefit::mlp {

enum class Trainer { Rprop, GradientDescent, LevenbergMarquardt };
const char* to_string(Trainer t);
bool parse(const std::string& s, Trainer& out);

/// Per-column standardisation: z = (x - mean) / scale.
struct Scaler {
  Eigen::RowVectorXd mean;
  Eigen::RowVectorXd scale;
  static Scaler fit(const Eigen::MatrixXd& x);
  Eigen::MatrixXd apply(const Eigen::MatrixXd& x) const;
  Eigen::MatrixXd invert(const Eigen::MatrixXd& z) const;
};

class Network {
 public:
  Network() = default;
  /// layers = {inputs, hidden..., outputs}; Glorot-uniform weights from the seed.
  Network(std::vector<std::size_t> layers, std::uint64_t seed);
  const std::vector<std::size_t>& layers() const { return layers_; }
  std::size_t parameter_count() const;
  /// x: samples x inputs -> samples x outputs.
  Eigen::MatrixXd predict(const Eigen::MatrixXd& x) const;
  Eigen::VectorXd parameters() const;
  void set_parameters(const Eigen::VectorXd& p);

  // Internals used by the trainers (column-major: features x samples).
  std::vector<Eigen::MatrixXd> forward(const Eigen::MatrixXd& xt) const;
  /// Gradient of 1/(N*outputs) * sum of squared errors, flattened like parameters().
  Eigen::VectorXd gradient(const Eigen::MatrixXd& xt, const Eigen::MatrixXd& yt, double* mse) const;
  /// Accumulates J^T J and J^T e for residual e = prediction - target over the samples.
  void gauss_newton(const Eigen::MatrixXd& xt, const Eigen::MatrixXd& yt, Eigen::MatrixXd& jtj,
                    Eigen::VectorXd& jte, double* sse) const;

 private:
  std::vector<std::size_t> layers_;
  std::vector<Eigen::MatrixXd> w_;  ///< w_[l]: layers[l+1] x layers[l]
  std::vector<Eigen::VectorXd> b_;
};

struct TrainSettings {
  std::vector<std::size_t> hidden{32, 32};
  Trainer trainer = Trainer::Rprop;
  std::size_t max_epochs = 1500;
  double validation_fraction = 0.15;
  std::size_t patience = 150;   ///< epochs without validation improvement before stopping
  double learning_rate = 0.05;  ///< gradient descent
  double momentum = 0.9;        ///< gradient descent
  std::uint64_t seed = 2;
};

struct TrainReport {
  std::size_t epochs = 0;
  std::size_t best_epoch = 0;
  double train_mse = 0.0;       ///< in scaled output units, at the best epoch
  double validation_mse = 0.0;  ///< idem
  bool early_stopped = false;
};

using Progress = std::function<void(std::size_t epoch, std::size_t max_epochs, double train_mse,
                                    double val_mse)>;

/// Trains on already scaled inputs/targets (rows = samples). The split into training and
/// validation samples is a seeded shuffle.
TrainReport train(Network& net, const Eigen::MatrixXd& x, const Eigen::MatrixXd& y,
                  const TrainSettings& s, const Progress& progress = {});

}  // namespace brakefit::mlp
