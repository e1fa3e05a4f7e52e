#include "core/som/som.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/rng.hpp"

namespace brakefit::som {

const char* to_string(Neighbourhood n) {
  switch (n) {
    case Neighbourhood::Gaussian:
      return "gaussian";
    case Neighbourhood::CutGauss:
      return "cutgauss";
    case Neighbourhood::Ep:
      return "ep";
    case Neighbourhood::Bubble:
      return "bubble";
  }
  return "?";
}
const char* to_string(Init i) {
  return i == Init::Random ? "random" : "linear";
}
const char* to_string(Algorithm a) {
  return a == Algorithm::Batch ? "batch" : "sequential";
}

bool parse(const std::string& s, Neighbourhood& out) {
  for (auto n :
       {Neighbourhood::Gaussian, Neighbourhood::CutGauss, Neighbourhood::Ep, Neighbourhood::Bubble})
    if (s == to_string(n)) return out = n, true;
  return false;
}
bool parse(const std::string& s, Init& out) {
  for (auto i : {Init::Random, Init::Linear})
    if (s == to_string(i)) return out = i, true;
  return false;
}
bool parse(const std::string& s, Algorithm& out) {
  for (auto a : {Algorithm::Batch, Algorithm::Sequential})
    if (s == to_string(a)) return out = a, true;
  return false;
}

double neighbourhood_weight(Neighbourhood n, double d, double r) {
  r = std::max(r, 1e-9);
  switch (n) {
    case Neighbourhood::Gaussian:
      return std::exp(-d * d / (2 * r * r));
    case Neighbourhood::CutGauss:
      return d <= r ? std::exp(-d * d / (2 * r * r)) : 0.0;
    case Neighbourhood::Ep:
      return d <= r ? 1.0 - d * d / (r * r) : 0.0;
    case Neighbourhood::Bubble:
      return d <= r ? 1.0 : 0.0;
  }
  return 0.0;
}

double radius_at(double r_ini, double r_fin, std::size_t t, std::size_t T) {
  if (T <= 1) return r_fin;
  return r_fin + (r_ini - r_fin) * static_cast<double>(T - t) / static_cast<double>(T - 1);
}

SomSettings with_default_radii(SomSettings s) {
  const double maxside = static_cast<double>(std::max(s.rows, s.cols));
  if (s.rough.radius_ini <= 0)
    s.rough.radius_ini = std::max(1.0, std::ceil(maxside / (s.init == Init::Random ? 4.0 : 8.0)));
  if (s.rough.radius_fin <= 0) s.rough.radius_fin = std::max(1.0, s.rough.radius_ini / 4.0);
  if (s.fine.radius_ini <= 0) s.fine.radius_ini = s.rough.radius_fin;
  if (s.fine.radius_fin <= 0) s.fine.radius_fin = 1.0;
  return s;
}

Som::Som(HexLattice lattice, Eigen::MatrixXd codebook)
    : lattice_(std::move(lattice)), codebook_(std::move(codebook)) {}

Som Som::initialise(const SomSettings& s, const Eigen::MatrixXd& data) {
  HexLattice lat(s.rows, s.cols);
  const auto u = static_cast<Eigen::Index>(lat.size());
  const auto dim = data.cols();
  Eigen::MatrixXd cb(u, dim);
  if (s.init == Init::Random) {
    Rng rng(s.seed);
    const Eigen::RowVectorXd lo = data.colwise().minCoeff(), hi = data.colwise().maxCoeff();
    for (Eigen::Index i = 0; i < u; ++i)
      for (Eigen::Index k = 0; k < dim; ++k) cb(i, k) = rng.uniform(lo(k), hi(k));
  } else {
    // Linear: mean + the two principal directions (scaled by sqrt of their eigenvalues) spanned
    // over unit coordinates normalised to [-1, 1]; the larger eigenvalue goes along the longer
    // side.
    const Eigen::RowVectorXd mean = data.colwise().mean();
    const Eigen::MatrixXd centred = data.rowwise() - mean;
    const Eigen::MatrixXd cov =
        centred.transpose() * centred / std::max<double>(1.0, static_cast<double>(data.rows() - 1));
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(cov);
    const Eigen::Index last = dim - 1;
    Eigen::VectorXd v1 =
        es.eigenvectors().col(last) * std::sqrt(std::max(0.0, es.eigenvalues()(last)));
    Eigen::VectorXd v2 = dim > 1
                             ? Eigen::VectorXd(es.eigenvectors().col(last - 1) *
                                               std::sqrt(std::max(0.0, es.eigenvalues()(last - 1))))
                             : Eigen::VectorXd::Zero(dim);
    double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
    for (std::size_t i = 0; i < lat.size(); ++i) {
      xmin = std::min(xmin, lat.x(i));
      xmax = std::max(xmax, lat.x(i));
      ymin = std::min(ymin, lat.y(i));
      ymax = std::max(ymax, lat.y(i));
    }
    const bool cols_longer = (xmax - xmin) >= (ymax - ymin);
    for (std::size_t i = 0; i < lat.size(); ++i) {
      const double cx = xmax > xmin ? 2 * (lat.x(i) - xmin) / (xmax - xmin) - 1 : 0.0;
      const double cy = ymax > ymin ? 2 * (lat.y(i) - ymin) / (ymax - ymin) - 1 : 0.0;
      const double a = cols_longer ? cx : cy, b = cols_longer ? cy : cx;
      cb.row(static_cast<Eigen::Index>(i)) = mean + (a * v1 + b * v2).transpose();
    }
  }
  return Som(std::move(lat), std::move(cb));
}

Eigen::MatrixXd Som::distances_sq(const Eigen::MatrixXd& data,
                                  const Eigen::VectorXd& data_sq) const {
  const Eigen::VectorXd cb_sq = codebook_.rowwise().squaredNorm();
  Eigen::MatrixXd d = -2.0 * data * codebook_.transpose();
  d.colwise() += data_sq;
  d.rowwise() += cb_sq.transpose();
  return d;
}

std::vector<std::size_t> Som::bmus(const Eigen::MatrixXd& data) const {
  const Eigen::VectorXd data_sq = data.rowwise().squaredNorm();
  const Eigen::MatrixXd d = distances_sq(data, data_sq);
  std::vector<std::size_t> out(static_cast<std::size_t>(data.rows()));
  for (Eigen::Index j = 0; j < data.rows(); ++j) {
    Eigen::Index best = 0;
    d.row(j).minCoeff(&best);
    out[static_cast<std::size_t>(j)] = static_cast<std::size_t>(best);
  }
  return out;
}

void Som::batch_epoch(const Eigen::MatrixXd& data, const Eigen::VectorXd& data_sq, Neighbourhood n,
                      double r) {
  const Eigen::MatrixXd d = distances_sq(data, data_sq);
  const auto u = codebook_.rows();
  Eigen::MatrixXd sums = Eigen::MatrixXd::Zero(u, codebook_.cols());
  Eigen::VectorXd counts = Eigen::VectorXd::Zero(u);
  for (Eigen::Index j = 0; j < data.rows(); ++j) {
    Eigen::Index best = 0;
    d.row(j).minCoeff(&best);
    sums.row(best) += data.row(j);
    counts(best) += 1.0;
  }
  Eigen::MatrixXd h(u, u);
  for (Eigen::Index a = 0; a < u; ++a)
    for (Eigen::Index b = 0; b < u; ++b)
      h(a, b) = neighbourhood_weight(n, lattice_.distances()(a, b), r);
  const Eigen::MatrixXd num = h * sums;
  const Eigen::VectorXd den = h * counts;
  for (Eigen::Index i = 0; i < u; ++i)
    if (den(i) > 0.0) codebook_.row(i) = num.row(i) / den(i);
}

void Som::train(const SomSettings& settings, const Eigen::MatrixXd& data,
                const Progress& progress) {
  const SomSettings s = with_default_radii(settings);
  const Eigen::VectorXd data_sq = data.rowwise().squaredNorm();
  Rng rng(s.seed ^ 0x9E3779B97F4A7C15ULL);
  const std::pair<const char*, const Phase*> phases[] = {{"rough", &s.rough}, {"fine", &s.fine}};
  for (const auto& [name, ph] : phases) {
    if (s.algorithm == Algorithm::Batch) {
      for (std::size_t t = 1; t <= ph->epochs; ++t) {
        batch_epoch(data, data_sq, s.neighbourhood,
                    radius_at(ph->radius_ini, ph->radius_fin, t, ph->epochs));
        if (progress) progress(name, t, ph->epochs);
      }
    } else {
      // Sequential: one step per sample, epochs * N steps, random order; alpha 'inv' schedule.
      const std::size_t n = static_cast<std::size_t>(data.rows());
      const std::size_t total = ph->epochs * n;
      const double b = total > 1 ? static_cast<double>(total - 1) / 99.0 : 1.0;
      const double a = b * ph->alpha_ini;
      std::size_t step = 0;
      for (std::size_t e = 1; e <= ph->epochs; ++e) {
        for (std::size_t k = 0; k < n; ++k) {
          ++step;
          const auto j = static_cast<Eigen::Index>(rng.index(n));
          const double r = radius_at(ph->radius_ini, ph->radius_fin, step, total);
          const double alpha =
              total > 1 ? a / (b + static_cast<double>(step) - 1.0) : ph->alpha_ini;
          const std::size_t c = bmu(data.row(j));
          for (Eigen::Index i = 0; i < codebook_.rows(); ++i) {
            const double h = neighbourhood_weight(
                s.neighbourhood, lattice_.distance(static_cast<std::size_t>(i), c), r);
            if (h > 0.0) codebook_.row(i) += alpha * h * (data.row(j) - codebook_.row(i));
          }
        }
        if (progress) progress(name, e, ph->epochs);
      }
    }
  }
}

std::size_t Som::bmu(const Eigen::Ref<const Eigen::RowVectorXd>& x) const {
  Eigen::Index best = 0;
  (codebook_.rowwise() - x).rowwise().squaredNorm().minCoeff(&best);
  return static_cast<std::size_t>(best);
}

std::pair<std::size_t, std::size_t> Som::two_bmus(
    const Eigen::Ref<const Eigen::RowVectorXd>& x) const {
  const Eigen::VectorXd d = (codebook_.rowwise() - x).rowwise().squaredNorm();
  std::size_t b1 = 0, b2 = 1;
  if (d(1) < d(0)) std::swap(b1, b2);
  for (Eigen::Index i = 2; i < d.size(); ++i) {
    const auto ui = static_cast<std::size_t>(i);
    if (d(i) < d(static_cast<Eigen::Index>(b1))) {
      b2 = b1;
      b1 = ui;
    } else if (d(i) < d(static_cast<Eigen::Index>(b2))) {
      b2 = ui;
    }
  }
  return {b1, b2};
}

Som::Match Som::bmu_masked(const std::vector<double>& x, const std::vector<bool>& mask,
                           bool scale_invariant, const std::vector<bool>* allowed) const {
  // With w the 0/1 mask and xw = x*w: sum_k w (x - s m)^2 = xx - 2 s (M xw) + s^2 ((M.^2) w), two
  // matrix-vector products over the whole codebook.
  const auto dim = codebook_.cols();
  Eigen::VectorXd w(dim), xw(dim);
  for (Eigen::Index k = 0; k < dim; ++k) {
    const bool on = mask[static_cast<std::size_t>(k)];
    w(k) = on ? 1.0 : 0.0;
    xw(k) = on ? x[static_cast<std::size_t>(k)] : 0.0;
  }
  const double xx = xw.squaredNorm();
  const Eigen::VectorXd xm = codebook_ * xw;
  const Eigen::VectorXd mm = codebook_.cwiseAbs2() * w;
  Match best;
  best.distance_sq = std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < codebook_.rows(); ++i) {
    if (allowed && !(*allowed)[static_cast<std::size_t>(i)]) continue;
    double scale = 1.0;
    double d;
    if (scale_invariant) {
      scale = mm(i) > 0 ? xm(i) / mm(i) : 0.0;
      d = xx - (mm(i) > 0 ? xm(i) * xm(i) / mm(i) : 0.0);
    } else {
      d = xx - 2.0 * xm(i) + mm(i);
    }
    if (d < best.distance_sq) best = {static_cast<std::size_t>(i), d, scale};
  }
  return best;
}

double Som::quantization_error(const Eigen::MatrixXd& data) const {
  double sum = 0.0;
  for (Eigen::Index j = 0; j < data.rows(); ++j)
    sum += (codebook_.row(static_cast<Eigen::Index>(bmu(data.row(j)))) - data.row(j)).norm();
  return data.rows() ? sum / static_cast<double>(data.rows()) : 0.0;
}

double Som::topographic_error(const Eigen::MatrixXd& data) const {
  std::size_t bad = 0;
  for (Eigen::Index j = 0; j < data.rows(); ++j) {
    const auto [b1, b2] = two_bmus(data.row(j));
    if (!lattice_.adjacent(b1, b2)) ++bad;
  }
  return data.rows() ? static_cast<double>(bad) / static_cast<double>(data.rows()) : 0.0;
}

Eigen::VectorXd Som::umatrix() const {
  Eigen::VectorXd u(codebook_.rows());
  for (Eigen::Index i = 0; i < codebook_.rows(); ++i) {
    const auto& nb = lattice_.neighbours(static_cast<std::size_t>(i));
    double s = 0.0;
    for (std::size_t j : nb)
      s += (codebook_.row(i) - codebook_.row(static_cast<Eigen::Index>(j))).norm();
    u(i) = nb.empty() ? 0.0 : s / static_cast<double>(nb.size());
  }
  return u;
}

}  // namespace brakefit::som
