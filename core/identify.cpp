#include "core/identify.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <future>

namespace brakefit {

const char* to_string(Basis b) {
  return b == Basis::Tyre ? "tyre" : "instrument";
}

std::vector<std::string> implausible_curve(const MfParams& p, double wheel_load_n,
                                           const TyreLimits& l) {
  std::vector<std::string> why;
  if (!(p.C >= l.min_C && p.C <= l.max_C))
    why.push_back(fmt::format("shape factor C {:.4g} outside [{:g}, {:g}]", p.C, l.min_C, l.max_C));
  if (std::isfinite(wheel_load_n) && wheel_load_n > 0) {
    const double mu = mf_peak(p, 1.0).force_n / wheel_load_n;
    if (!(mu >= l.min_peak_friction && mu <= l.max_peak_friction))
      why.push_back(
          fmt::format("peak friction {:.2f} (peak force / wheel load {:.0f} N) outside "
                      "[{:g}, {:g}]",
                      mu, wheel_load_n, l.min_peak_friction, l.max_peak_friction));
  }
  return why;
}

void flag_implausible(MethodResult& r, double wheel_load_n) {
  const auto why = implausible_curve(r.params, wheel_load_n);
  r.implausible.insert(r.implausible.end(), why.begin(), why.end());
}

const char* to_string(Method m) {
  switch (m) {
    case Method::Som:
      return "som";
    case Method::Mlp:
      return "mlp";
    case Method::Lm:
      return "lm";
    case Method::Hybrid:
      return "hybrid";
  }
  return "?";
}

bool parse(const std::string& s, Method& out) {
  for (auto m : {Method::Som, Method::Mlp, Method::Lm, Method::Hybrid})
    if (s == to_string(m)) return out = m, true;
  return false;
}

std::vector<double> normalise_shape(const GridCurve& g) {
  double peak = 0.0;
  for (std::size_t k = 0; k < g.values.size(); ++k)
    if (g.mask[k]) peak = std::max(peak, std::abs(g.values[k]));
  std::vector<double> s(g.values.size(), 0.0);
  if (peak <= 0) return s;
  for (std::size_t k = 0; k < s.size(); ++k)
    if (g.mask[k]) s[k] = g.values[k] / peak;
  return s;
}

Eigen::RowVectorXd mlp_features(const GridCurve& g, const std::vector<double>& grid) {
  const std::vector<double> s = normalise_shape(g);
  Eigen::RowVectorXd f(static_cast<Eigen::Index>(s.size() + 1));
  for (std::size_t k = 0; k < s.size(); ++k) f(static_cast<Eigen::Index>(k)) = s[k];
  f(static_cast<Eigen::Index>(s.size())) = g.last_valid_slip(grid);
  return f;
}

double fit_scale_D(const Curve& c, double B, double C, double E) {
  const MfParams unit{B, C, 1.0, E, 0.0, 0.0};
  double fs = 0.0, ss = 0.0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const double s = mf_force_n(unit, c.slip_ratio[i]);
    fs += c.force_n[i] * s;
    ss += s * s;
  }
  return ss > 0 ? fs / ss : 0.0;
}

SomEstimate identify_som(const Model& m, const Curve& c) {
  const GridCurve g = resample_to_grid(c, m.grid);
  const bool shape = m.config.som_input == SomInput::Shape;
  SomEstimate est;
  auto match = m.som.bmu_masked(g.values, g.mask, shape);
  if (m.unit_hits[match.unit] == 0) {
    std::vector<bool> allowed(m.unit_hits.size());
    for (std::size_t u = 0; u < allowed.size(); ++u) allowed[u] = m.unit_hits[u] > 0;
    match = m.som.bmu_masked(g.values, g.mask, shape, &allowed);
    est.fallback = true;
  }
  est.bmu = match.unit;
  est.params = m.unit_labels[match.unit];
  if (shape) est.params.D = fit_scale_D(c, est.params.B, est.params.C, est.params.E);
  return est;
}

std::vector<std::string> mlp_outside_training(const Model& m, const Curve& c) {
  // Training masks the grid past its cut, so a curve cut at r ends on the last grid point at or
  // below r: the ends it saw are those of the cut range, and the grid's end (the curves it left
  // whole). A curve ending between the longest cut and the grid's end is as new to the network
  // as a shorter one (a model cut at 4-60 % returned E 2 for a car's curve to 87 % slip).
  auto on_grid = [&](double r) {
    const auto past = std::upper_bound(m.grid.begin(), m.grid.end(), r + 1e-12);
    return past == m.grid.begin() ? r : *std::prev(past);
  };
  const bool cut = m.config.mlp_truncate_fraction > 0;
  const double shortest = cut ? m.config.mlp_truncate_min_ratio : m.grid.back();
  const double longest = cut ? on_grid(m.config.mlp_truncate_max_ratio) : m.grid.back();
  const double ends = resample_to_grid(c, m.grid).last_valid_slip(m.grid);
  if (ends < on_grid(shortest) - 1e-12)
    return {fmt::format(
        "MLP extrapolating: the curve ends at {:.1f} % slip, the network was trained on curves "
        "reaching at least {:.1f} %",
        100.0 * ends, 100.0 * shortest)};
  if (ends > longest + 1e-12 && ends < m.grid.back() - 1e-12)
    return {fmt::format(
        "MLP extrapolating: the curve ends at {:.1f} % slip, the network was trained on curves "
        "cut at {:.1f} % or shorter, or reaching {:.1f} %",
        100.0 * ends, 100.0 * m.config.mlp_truncate_max_ratio, 100.0 * m.grid.back())};
  return {};
}

std::vector<std::string> mlp_estimate_outside_training(const Model& m, const MfParams& p) {
  const auto& families = m.config.database.families;
  if (families.empty()) return {};
  std::vector<std::string> out;
  auto check = [&](const char* name, double v, ParamRange TyreFamily::*range) {
    ParamRange all = families.front().*range;
    for (const auto& f : families) {
      all.lo = std::min(all.lo, (f.*range).lo);
      all.hi = std::max(all.hi, (f.*range).hi);
    }
    const double margin = kMlpOutputMargin * (all.hi - all.lo);
    if (v >= all.lo - margin && v <= all.hi + margin) return;
    out.push_back(fmt::format(
        "MLP extrapolating: its {} {:.3g} lies outside the {} of every curve it was trained on "
        "({:.3g} to {:.3g})",
        name, v, name, all.lo, all.hi));
  };
  check("B", p.B, &TyreFamily::B);
  check("C", p.C, &TyreFamily::C);
  check("E", p.E, &TyreFamily::E);
  return out;
}

MfParams identify_mlp(const Model& m, const Curve& c) {
  const GridCurve g = resample_to_grid(c, m.grid);
  const Eigen::MatrixXd x = m.mlp_in.apply(mlp_features(g, m.grid));
  Eigen::MatrixXd y = Eigen::MatrixXd::Zero(1, 3);
  for (const auto& net : m.mlp) y += m.mlp_out.invert(net.predict(x));
  y /= static_cast<double>(m.mlp.size());
  MfParams p;
  p.B = std::exp(y(0, 0));
  p.C = y(0, 1);
  p.E = y(0, 2);
  p.D = fit_scale_D(c, p.B, p.C, p.E);
  return p;
}

fit::MfFitOptions fit_options_for(const Model* m) {
  fit::MfFitOptions o;
  if (!m) return o;
  for (const auto& f : m->config.database.families) {
    o.bounds.E_hi = std::max(o.bounds.E_hi, f.E.hi);
    o.bounds.E_lo = std::min(o.bounds.E_lo, f.E.lo);
    o.bounds.B_hi = std::max(o.bounds.B_hi, 2.0 * f.B.hi);
    o.bounds.C_lo = std::min(o.bounds.C_lo, f.C.lo);
    o.bounds.C_hi = std::max(o.bounds.C_hi, f.C.hi);
  }
  return o;
}

MethodResult run_method(Method method, const Model* model, const Curve& c,
                        const fit::MfFitOptions& options, bool parallel) {
  MethodResult r;
  r.method = method;
  switch (method) {
    case Method::Som: {
      const SomEstimate e = identify_som(*model, c);
      r.params = e.params;
      r.bmu = e.bmu;
      break;
    }
    case Method::Mlp:
      r.params = identify_mlp(*model, c);
      r.implausible = mlp_outside_training(*model, c);
      for (std::string& why : mlp_estimate_outside_training(*model, r.params))
        r.implausible.push_back(std::move(why));
      break;
    case Method::Lm: {
      const fit::MfFitResult f = fit::fit_mf(c, fit::classic_start(c), options);
      r.params = f.params;
      r.stderr_ = f.stderr_;
      r.at_bound = f.at_bound;
      r.stderr_null_reason = f.stderr_null_reason;
      r.iterations = f.iterations;
      r.converged = f.converged;
      break;
    }
    case Method::Hybrid: {
      // LM from the SOM estimate and from the MLP estimate; the lower sum of squares wins.
      const SomEstimate e = identify_som(*model, c);
      auto mlp_job = std::async(parallel ? std::launch::async : std::launch::deferred,
                                [&] { return fit::fit_mf(c, identify_mlp(*model, c), options); });
      fit::MfFitResult best = fit::fit_mf(c, e.params, options);
      const fit::MfFitResult from_mlp = mlp_job.get();
      if (from_mlp.ssr < best.ssr) best = from_mlp;
      r.params = best.params;
      r.stderr_ = best.stderr_;
      r.at_bound = best.at_bound;
      r.stderr_null_reason = best.stderr_null_reason;
      r.iterations = best.iterations;
      r.converged = best.converged;
      r.bmu = e.bmu;
      break;
    }
  }
  r.metrics = compute_metrics(c, r.params);
  r.peak_reached = fit::peak_reached(r.params, c.max_slip_ratio());
  return r;
}

}  // namespace brakefit
