#include "core/mlp/mlp.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/rng.hpp"

namespace brakefit::mlp {

const char* to_string(Trainer t) {
  switch (t) {
    case Trainer::Rprop:
      return "rprop";
    case Trainer::GradientDescent:
      return "gd";
    case Trainer::LevenbergMarquardt:
      return "lm";
  }
  return "?";
}

bool parse(const std::string& s, Trainer& out) {
  for (auto t : {Trainer::Rprop, Trainer::GradientDescent, Trainer::LevenbergMarquardt})
    if (s == to_string(t)) return out = t, true;
  return false;
}

Scaler Scaler::fit(const Eigen::MatrixXd& x) {
  Scaler s;
  s.mean = x.colwise().mean();
  s.scale = ((x.rowwise() - s.mean).array().square().colwise().sum() /
             std::max<double>(1.0, static_cast<double>(x.rows())))
                .sqrt()
                .matrix();
  for (Eigen::Index k = 0; k < s.scale.size(); ++k)
    if (!(s.scale(k) > 1e-12)) s.scale(k) = 1.0;  // constant column
  return s;
}

Eigen::MatrixXd Scaler::apply(const Eigen::MatrixXd& x) const {
  return ((x.rowwise() - mean).array().rowwise() / scale.array()).matrix();
}

Eigen::MatrixXd Scaler::invert(const Eigen::MatrixXd& z) const {
  return ((z.array().rowwise() * scale.array()).rowwise() + mean.array()).matrix();
}

Network::Network(std::vector<std::size_t> layers, std::uint64_t seed) : layers_(std::move(layers)) {
  Rng rng(seed);
  for (std::size_t l = 0; l + 1 < layers_.size(); ++l) {
    const auto in = static_cast<Eigen::Index>(layers_[l]),
               out = static_cast<Eigen::Index>(layers_[l + 1]);
    const double lim = std::sqrt(6.0 / static_cast<double>(in + out));
    Eigen::MatrixXd w(out, in);
    for (Eigen::Index i = 0; i < out; ++i)
      for (Eigen::Index j = 0; j < in; ++j) w(i, j) = rng.uniform(-lim, lim);
    w_.push_back(std::move(w));
    b_.push_back(Eigen::VectorXd::Zero(out));
  }
}

std::size_t Network::parameter_count() const {
  std::size_t n = 0;
  for (std::size_t l = 0; l < w_.size(); ++l)
    n += static_cast<std::size_t>(w_[l].size() + b_[l].size());
  return n;
}

Eigen::VectorXd Network::parameters() const {
  Eigen::VectorXd p(static_cast<Eigen::Index>(parameter_count()));
  Eigen::Index o = 0;
  for (std::size_t l = 0; l < w_.size(); ++l) {
    p.segment(o, w_[l].size()) = Eigen::Map<const Eigen::VectorXd>(w_[l].data(), w_[l].size());
    o += w_[l].size();
    p.segment(o, b_[l].size()) = b_[l];
    o += b_[l].size();
  }
  return p;
}

void Network::set_parameters(const Eigen::VectorXd& p) {
  Eigen::Index o = 0;
  for (std::size_t l = 0; l < w_.size(); ++l) {
    Eigen::Map<Eigen::VectorXd>(w_[l].data(), w_[l].size()) = p.segment(o, w_[l].size());
    o += w_[l].size();
    b_[l] = p.segment(o, b_[l].size());
    o += b_[l].size();
  }
}

std::vector<Eigen::MatrixXd> Network::forward(const Eigen::MatrixXd& xt) const {
  std::vector<Eigen::MatrixXd> a;
  a.reserve(w_.size() + 1);
  a.push_back(xt);
  for (std::size_t l = 0; l < w_.size(); ++l) {
    Eigen::MatrixXd z = w_[l] * a.back();
    z.colwise() += b_[l];
    if (l + 1 < w_.size()) z = z.array().tanh().matrix();
    a.push_back(std::move(z));
  }
  return a;
}

Eigen::MatrixXd Network::predict(const Eigen::MatrixXd& x) const {
  return forward(x.transpose()).back().transpose();
}

Eigen::VectorXd Network::gradient(const Eigen::MatrixXd& xt, const Eigen::MatrixXd& yt,
                                  double* mse) const {
  const auto a = forward(xt);
  const double norm = static_cast<double>(yt.size());
  Eigen::MatrixXd delta = a.back() - yt;
  if (mse) *mse = delta.squaredNorm() / norm;
  delta *= 2.0 / norm;
  Eigen::VectorXd g(static_cast<Eigen::Index>(parameter_count()));
  // Offsets of each layer's block in the flat vector.
  std::vector<Eigen::Index> off(w_.size());
  Eigen::Index o = 0;
  for (std::size_t l = 0; l < w_.size(); ++l) {
    off[l] = o;
    o += w_[l].size() + b_[l].size();
  }
  for (std::size_t l = w_.size(); l-- > 0;) {
    const Eigen::MatrixXd gw = delta * a[l].transpose();
    g.segment(off[l], gw.size()) = Eigen::Map<const Eigen::VectorXd>(gw.data(), gw.size());
    g.segment(off[l] + gw.size(), b_[l].size()) = delta.rowwise().sum();
    if (l > 0)
      delta = ((w_[l].transpose() * delta).array() * (1.0 - a[l].array().square())).matrix();
  }
  return g;
}

void Network::gauss_newton(const Eigen::MatrixXd& xt, const Eigen::MatrixXd& yt,
                           Eigen::MatrixXd& jtj, Eigen::VectorXd& jte, double* sse) const {
  const auto a = forward(xt);
  const Eigen::MatrixXd err = a.back() - yt;
  if (sse) *sse += err.squaredNorm();
  const auto p = static_cast<Eigen::Index>(parameter_count());
  const Eigen::Index n = xt.cols();
  const Eigen::Index outs = yt.rows();
  std::vector<Eigen::Index> off(w_.size());
  Eigen::Index o = 0;
  for (std::size_t l = 0; l < w_.size(); ++l) {
    off[l] = o;
    o += w_[l].size() + b_[l].size();
  }
  // Jacobian rows for every (output, sample): d prediction / d parameters.
  Eigen::MatrixXd j(outs * n, p);
  for (Eigen::Index out = 0; out < outs; ++out) {
    Eigen::MatrixXd delta = Eigen::MatrixXd::Zero(outs, n);
    delta.row(out).setOnes();
    for (std::size_t l = w_.size(); l-- > 0;) {
      const Eigen::Index in = a[l].rows(), ol = delta.rows();
      for (Eigen::Index s = 0; s < n; ++s) {
        const Eigen::Index row = out * n + s;
        // dW(i, k) = delta(i, s) * a(k, s), column-major flattening (i fastest).
        for (Eigen::Index k = 0; k < in; ++k)
          j.row(row).segment(off[l] + k * ol, ol) = delta.col(s).transpose() * a[l](k, s);
        j.row(row).segment(off[l] + ol * in, ol) = delta.col(s).transpose();
      }
      if (l > 0)
        delta = ((w_[l].transpose() * delta).array() * (1.0 - a[l].array().square())).matrix();
    }
  }
  Eigen::VectorXd e(outs * n);
  for (Eigen::Index out = 0; out < outs; ++out) e.segment(out * n, n) = err.row(out).transpose();
  jtj.selfadjointView<Eigen::Lower>().rankUpdate(j.transpose());
  jte += j.transpose() * e;
}

namespace {

double mse_of(const Network& net, const Eigen::MatrixXd& xt, const Eigen::MatrixXd& yt) {
  if (xt.cols() == 0) return 0.0;
  return (net.forward(xt).back() - yt).squaredNorm() / static_cast<double>(yt.size());
}

}  // namespace

TrainReport train(Network& net, const Eigen::MatrixXd& x, const Eigen::MatrixXd& y,
                  const TrainSettings& s, const Progress& progress) {
  const auto n = static_cast<std::size_t>(x.rows());
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  Rng rng(s.seed ^ 0xA5A5A5A5ULL);
  for (std::size_t i = n; i > 1; --i) std::swap(order[i - 1], order[rng.index(i)]);
  const auto n_val =
      static_cast<std::size_t>(std::floor(s.validation_fraction * static_cast<double>(n)));
  const std::size_t n_tr = n - n_val;
  Eigen::MatrixXd xt(x.cols(), static_cast<Eigen::Index>(n_tr)),
      yt(y.cols(), static_cast<Eigen::Index>(n_tr));
  Eigen::MatrixXd xv(x.cols(), static_cast<Eigen::Index>(n_val)),
      yv(y.cols(), static_cast<Eigen::Index>(n_val));
  for (std::size_t i = 0; i < n; ++i) {
    const auto src = static_cast<Eigen::Index>(order[i]);
    if (i < n_tr) {
      xt.col(static_cast<Eigen::Index>(i)) = x.row(src).transpose();
      yt.col(static_cast<Eigen::Index>(i)) = y.row(src).transpose();
    } else {
      xv.col(static_cast<Eigen::Index>(i - n_tr)) = x.row(src).transpose();
      yv.col(static_cast<Eigen::Index>(i - n_tr)) = y.row(src).transpose();
    }
  }
  const bool have_val = n_val > 0;
  TrainReport rep;
  Eigen::VectorXd w = net.parameters();
  Eigen::VectorXd best_w = w;
  double best_val = INFINITY;
  const auto p = w.size();
  // Rprop state
  Eigen::VectorXd step = Eigen::VectorXd::Constant(p, 0.01), g_prev = Eigen::VectorXd::Zero(p);
  // Gradient descent state
  Eigen::VectorXd velocity = Eigen::VectorXd::Zero(p);
  // Levenberg-Marquardt state
  double mu = 1e-3;
  std::size_t since_best = 0;
  for (std::size_t epoch = 1; epoch <= s.max_epochs; ++epoch) {
    double train_mse = 0.0;
    if (s.trainer == Trainer::LevenbergMarquardt) {
      Eigen::MatrixXd jtj = Eigen::MatrixXd::Zero(p, p);
      Eigen::VectorXd jte = Eigen::VectorXd::Zero(p);
      double sse = 0.0;
      constexpr Eigen::Index kChunk = 256;
      for (Eigen::Index c0 = 0; c0 < xt.cols(); c0 += kChunk) {
        const Eigen::Index len = std::min(kChunk, xt.cols() - c0);
        net.gauss_newton(xt.middleCols(c0, len), yt.middleCols(c0, len), jtj, jte, &sse);
      }
      const Eigen::MatrixXd full = jtj.selfadjointView<Eigen::Lower>();
      bool accepted = false;
      for (int tries = 0; tries < 12 && !accepted; ++tries) {
        Eigen::MatrixXd a = full;
        a.diagonal().array() += mu;
        const Eigen::VectorXd dw = a.ldlt().solve(-jte);
        net.set_parameters(w + dw);
        const double new_sse = mse_of(net, xt, yt) * static_cast<double>(yt.size());
        if (new_sse < sse) {
          w += dw;
          mu = std::max(mu / 10.0, 1e-12);
          accepted = true;
          train_mse = new_sse / static_cast<double>(yt.size());
        } else {
          mu = std::min(mu * 10.0, 1e12);
        }
      }
      if (!accepted) {
        net.set_parameters(w);
        train_mse = sse / static_cast<double>(yt.size());
      }
    } else {
      net.set_parameters(w);
      const Eigen::VectorXd g = net.gradient(xt, yt, &train_mse);
      if (s.trainer == Trainer::Rprop) {
        for (Eigen::Index i = 0; i < p; ++i) {
          const double prod = g(i) * g_prev(i);
          double gi = g(i);
          if (prod > 0) {
            step(i) = std::min(step(i) * 1.2, 1.0);
          } else if (prod < 0) {
            step(i) = std::max(step(i) * 0.5, 1e-8);
            gi = 0.0;  // iRprop-: skip this update and forget the gradient
          }
          if (gi > 0)
            w(i) -= step(i);
          else if (gi < 0)
            w(i) += step(i);
          g_prev(i) = gi;
        }
      } else {
        velocity = s.momentum * velocity - s.learning_rate * g;
        w += velocity;
      }
      net.set_parameters(w);
    }
    const double val_mse = have_val ? mse_of(net, xv, yv) : train_mse;
    if (val_mse < best_val) {
      best_val = val_mse;
      best_w = w;
      rep.best_epoch = epoch;
      rep.train_mse = train_mse;
      since_best = 0;
    } else if (++since_best >= s.patience) {
      rep.early_stopped = true;
      rep.epochs = epoch;
      if (progress) progress(epoch, s.max_epochs, train_mse, val_mse);
      break;
    }
    rep.epochs = epoch;
    if (progress) progress(epoch, s.max_epochs, train_mse, val_mse);
  }
  net.set_parameters(best_w);
  rep.validation_mse = best_val;
  return rep;
}

}  // namespace brakefit::mlp
