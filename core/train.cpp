#include "core/train.hpp"

#include <cmath>
#include <future>
#include <utility>

#include "core/rng.hpp"

namespace brakefit {

Eigen::MatrixXd som_input_matrix(const CurveDatabase& db, SomInput input) {
  Eigen::MatrixXd x = db.forces_n;
  if (input == SomInput::Shape) {
    for (Eigen::Index i = 0; i < x.rows(); ++i) {
      const double peak = x.row(i).cwiseAbs().maxCoeff();
      if (peak > 0) x.row(i) /= peak;
    }
  }
  return x;
}

void label_units(Model& m, const CurveDatabase& db, const Eigen::MatrixXd& som_data) {
  const std::size_t u = m.som.units();
  m.unit_hits.assign(u, 0);
  std::vector<std::array<double, 4>> sums(u, {0, 0, 0, 0});
  const auto bmus = m.som.bmus(som_data);
  for (std::size_t j = 0; j < bmus.size(); ++j) {
    const MfParams& p = db.labels[j];
    auto& s = sums[bmus[j]];
    s[0] += p.B;
    s[1] += p.C;
    s[2] += p.D;
    s[3] += p.E;
    ++m.unit_hits[bmus[j]];
  }
  m.unit_labels.assign(u, MfParams{0, 0, 0, 0, 0, 0});
  for (std::size_t i = 0; i < u; ++i) {
    if (!m.unit_hits[i]) continue;
    const double n = static_cast<double>(m.unit_hits[i]);
    m.unit_labels[i] =
        MfParams{sums[i][0] / n, sums[i][1] / n, sums[i][2] / n, sums[i][3] / n, 0, 0};
  }
  m.som_qe = m.som.quantization_error(som_data);
  m.som_te = m.som.topographic_error(som_data);
}

namespace {

void train_som_part(Model& m, const CurveDatabase& db, const TrainProgress& progress) {
  const Eigen::MatrixXd x = som_input_matrix(db, m.config.som_input);
  m.som = som::Som::initialise(m.config.som, x);
  m.som.train(m.config.som, x, [&](const char* phase, std::size_t e, std::size_t total) {
    if (progress) progress(std::string("som-") + phase, e, total, NAN);
  });
  label_units(m, db, x);
}

/// Generates the database and trains the SOM; the database is returned for the MLP.
CurveDatabase train_som_stage(Model& m, const TrainConfig& c, const TrainProgress& progress) {
  m.config = c;
  m.grid = default_slip_grid();
  CurveDatabase db = generate_database(c.database, m.grid);
  train_som_part(m, db, progress);
  return db;
}

}  // namespace

Model train_som_only(const TrainConfig& c, const TrainProgress& progress) {
  Model m;
  train_som_stage(m, c, progress);
  return m;
}

Model train_model(const TrainConfig& c, const TrainProgress& progress) {
  Model m;
  const CurveDatabase db = train_som_stage(m, c, progress);

  // MLP: features of each database curve, a share of them cut short at a random slip (as a roller
  // test that switches off early), targets log B, C, E.
  const auto n = static_cast<Eigen::Index>(db.labels.size());
  const auto g = static_cast<Eigen::Index>(m.grid.size());
  Eigen::MatrixXd x(n, g + 1), y(n, 3);
  Rng rng(c.mlp.seed ^ 0x5DEECE66DULL);
  for (Eigen::Index i = 0; i < n; ++i) {
    GridCurve gc;
    gc.values.assign(m.grid.size(), 0.0);
    gc.mask.assign(m.grid.size(), true);
    for (Eigen::Index k = 0; k < g; ++k) gc.values[static_cast<std::size_t>(k)] = db.forces_n(i, k);
    if (rng.uniform() < c.mlp_truncate_fraction) {
      const double cut = rng.uniform(c.mlp_truncate_min_ratio, c.mlp_truncate_max_ratio);
      for (std::size_t k = 0; k < m.grid.size(); ++k) gc.mask[k] = m.grid[k] <= cut + 1e-12;
    }
    x.row(i) = mlp_features(gc, m.grid);
    const MfParams& p = db.labels[static_cast<std::size_t>(i)];
    y.row(i) << std::log(p.B), p.C, p.E;
  }
  m.mlp_in = mlp::Scaler::fit(x);
  m.mlp_out = mlp::Scaler::fit(y);
  std::vector<std::size_t> layers{static_cast<std::size_t>(g + 1)};
  layers.insert(layers.end(), c.mlp.hidden.begin(), c.mlp.hidden.end());
  layers.push_back(3);
  const Eigen::MatrixXd xs = m.mlp_in.apply(x), ys = m.mlp_out.apply(y);
  // The ensemble's networks differ only in their seeds (weights and validation split); each is
  // trained on its own thread and reproducibly, whatever the threads. The first reports progress.
  std::vector<std::future<std::pair<mlp::Network, mlp::TrainReport>>> jobs;
  for (std::size_t k = 0; k < c.mlp_ensemble; ++k)
    jobs.push_back(std::async(std::launch::async, [&, k] {
      mlp::TrainSettings s = c.mlp;
      s.seed = c.mlp.seed + k;
      mlp::Network net(layers, s.seed);
      mlp::TrainReport r =
          mlp::train(net, xs, ys, s, [&](std::size_t e, std::size_t total, double tr, double) {
            if (progress && k == 0) progress("mlp", e, total, tr);
          });
      return std::pair{std::move(net), r};
    }));
  for (auto& j : jobs) {
    auto [net, r] = j.get();
    m.mlp.push_back(std::move(net));
    m.mlp_report.push_back(r);
  }
  return m;
}

}  // namespace brakefit
