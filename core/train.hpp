#pragma once
// Trains a model from a configuration: generate the curve database, train the SOM on it (shapes or
// raw curves), label the units, train the MLP. Deterministic from the configured seeds.
#include <functional>
#include <string>

#include "core/identify.hpp"

namespace brakefit {

/// stage: "som-rough", "som-fine", "mlp"; done/total within the stage; loss for mlp (else NaN).
using TrainProgress =
    std::function<void(const std::string& stage, std::size_t done, std::size_t total, double loss)>;

/// The SOM input matrix for a database (rows = curves): peak-normalised shapes or raw forces.
Eigen::MatrixXd som_input_matrix(const CurveDatabase& db, SomInput input);
/// Computes unit hits and mean labels of the database curves on the trained map.
void label_units(Model& m, const CurveDatabase& db, const Eigen::MatrixXd& som_data);

Model train_som_only(const TrainConfig& c, const TrainProgress& progress = {});
Model train_model(const TrainConfig& c, const TrainProgress& progress = {});

}  // namespace brakefit
