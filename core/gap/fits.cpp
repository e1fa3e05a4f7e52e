// Joint least-squares fits of B, C, D, E and the effects' parameters over runs (or the effects
// alone with B, C, D, E held), by the bounded Levenberg-Marquardt of core/fit.
#include <algorithm>
#include <cmath>
#include <optional>

#include "core/fit/lm.hpp"
#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "core/gap/predict_cache.hpp"
#include "core/gap/warm_fit.hpp"

namespace brakefit::gap {

double Fit::bic() const {
  const double n = static_cast<double>(points);
  return n * std::log(std::max(ssr, 1e-300) / n) + static_cast<double>(params.size()) * std::log(n);
}

namespace {

class GapProblem final : public fit::LeastSquaresProblem {
 public:
  GapProblem(const std::vector<const Run*>& runs, const std::vector<Effect>& effects,
             std::vector<double> fixed_base = {})
      : runs_(runs), effects_(effects), base_(std::move(fixed_base)) {
    for (const Run* r : runs_) n_ += static_cast<Eigen::Index>(r->fitted_points());
  }
  Eigen::Index residual_count() const override { return n_; }
  void evaluate(const Eigen::VectorXd& x, Eigen::VectorXd& res, Eigen::MatrixXd* j) const override {
    residuals(x, res);
    if (!j) return;
    Eigen::VectorXd rp(n_), rm(n_);
    for (Eigen::Index k = 0; k < x.size(); ++k) {
      const double h = 1e-6 * std::max(1.0, std::abs(x(k)));
      Eigen::VectorXd xp = x, xm = x;
      xp(k) += h;
      xm(k) -= h;
      residuals(xp, rp);
      residuals(xm, rm);
      j->col(k) = (rp - rm) / (2 * h);
    }
  }

 private:
  void residuals(const Eigen::VectorXd& x, Eigen::VectorXd& res) const {
    std::vector<double> p = base_;  // empty unless B, C, D, E are held
    p.insert(p.end(), x.data(), x.data() + x.size());
    Eigen::Index o = 0;
    for (const Run* r : runs_) {
      const auto f = predict(*r, p, effects_, &cache_);
      for (std::size_t i = 0; i < f.size(); ++i)
        if (r->fitted_at(i)) res(o++) = f[i] - r->force_n[i];
    }
  }
  const std::vector<const Run*>& runs_;
  const std::vector<Effect>& effects_;
  std::vector<double> base_;
  Eigen::Index n_ = 0;
  mutable PredictCache cache_;  // the fit's evaluations ask the same pitch, relaxation, filter
};

}  // namespace

Eigen::MatrixXd prediction_jacobian(const std::vector<const Run*>& runs,
                                    const std::vector<double>& params,
                                    const std::vector<Effect>& effects) {
  const GapProblem problem(runs, effects);
  Eigen::VectorXd res(problem.residual_count());
  Eigen::MatrixXd jac(problem.residual_count(), static_cast<Eigen::Index>(params.size()));
  problem.evaluate(
      Eigen::Map<const Eigen::VectorXd>(params.data(), static_cast<Eigen::Index>(params.size())),
      res, &jac);
  return jac;
}

namespace {

struct ParamRange {
  double lo, hi, start;
};
/// An effect parameter's fit range: its physical range, but the cradle cap's from the runs' peak
/// force (it starts there) and the nuisance slip bias's from the runs' quantisation and the
/// tyre's shift (nuisance_bias_bound).
ParamRange param_range(Effect e, const EffectParam& ep, const std::vector<const Run*>& runs,
                       double peak, const std::vector<Effect>& model) {
  if (e == Effect::CradleCap) return {0.3 * peak, 2.0 * peak, peak};
  if (e == Effect::SlipOffset && !runs.empty() && std::isfinite(runs.front()->foot_pin_ratio)) {
    const double pin = runs.front()->foot_pin_ratio, tol = runs.front()->foot_pin_tol_ratio;
    return {std::max(ep.lo, pin - tol), std::min(ep.hi, pin + tol), pin};
  }
  if (is_nuisance(e)) {
    const double bound = std::max(1e-12, nuisance_bias_bound(runs, model));
    return {-bound, bound, 0.0};
  }
  return {ep.lo, ep.hi, ep.start};
}

bool contains(const std::vector<Effect>& model, Effect e) {
  return std::find(model.begin(), model.end(), e) != model.end();
}

}  // namespace

EffectScore score_at(Effect e, const std::vector<Effect>& model, const Fit& f) {
  EffectScore s;
  s.effect = e;
  const auto at = *param_offset(model, e);
  const auto eps = effect_params(e);
  for (std::size_t j = 0; j < eps.size(); ++j) s.params.emplace_back(eps[j].name, f.params[at + j]);
  return s;
}

std::vector<Effect> named_effects(const std::vector<Effect>& model) {
  std::vector<Effect> out;
  for (Effect e : model)
    if (!is_nuisance(e)) out.push_back(e);
  return out;
}

namespace {

/// Half a quantisation step of a constant reference, the largest over the runs (0: none).
double quantisation_bias_bound(const std::vector<const Run*>& runs) {
  double bound = 0;
  for (const Run* r : runs) bound = std::max(bound, r->ref_bias_bound);
  return bound;
}

/// The fit's standard errors, but the slip offset's with the nuisance slip bias held: both add to
/// the same slip, so while both are free only their sum has an error (a 0.8 % offset beside a
/// quantised roller's bias of at most 0.1 % read +- 32). The bias is bounded to its half step, so
/// held it does not hide an offset larger than that. `head` is the number of curve parameters
/// before the effects' in the result (4, or 0 where the curve was held).
std::vector<double> gap_standard_errors(const fit::LmResult& r, const std::vector<Effect>& effects,
                                        std::size_t head) {
  std::vector<double> out(r.standard_errors.data(),
                          r.standard_errors.data() + r.standard_errors.size());
  const auto at = [&](Effect e) -> std::optional<std::size_t> {
    const auto k = param_offset(effects, e);  // counts the 4 curve parameters
    return k ? std::optional<std::size_t>(*k - 4 + head) : std::nullopt;
  };
  const auto offset = at(Effect::SlipOffset);
  std::vector<bool> held(out.size());
  bool any_held = false;
  for (const Effect e : effects)
    if (is_nuisance(e)) held.at(*at(e)) = any_held = true;
  if (!offset || !any_held) return out;
  out.at(*offset) = fit::standard_errors_holding(r, held)(static_cast<Eigen::Index>(*offset));
  return out;
}

}  // namespace

double nuisance_bias_bound(const std::vector<const Run*>& runs, const std::vector<Effect>& model) {
  const bool shift = contains(model, Effect::TyreShift) && !contains(model, Effect::SlipOffset);
  return quantisation_bias_bound(runs) + (shift ? kTyreShiftBoundRatio : 0.0);
}

bool tyre_shift_inside(const Fit& f, const std::vector<Effect>& model,
                       const std::vector<const Run*>& runs) {
  const auto at = param_offset(model, Effect::TyreShift);
  return !at || std::abs(f.params.at(*at)) < 0.99 * nuisance_bias_bound(runs, model);
}

std::vector<Effect> without_tyre_shift(const std::vector<Effect>& model,
                                       const std::vector<const Run*>& runs) {
  const bool quantised = quantisation_bias_bound(runs) > 0;
  std::vector<Effect> out;
  for (Effect e : model)
    if (e != Effect::TyreShift)
      out.push_back(e);
    else if (quantised)
      out.push_back(Effect::ReferenceBias);
  return out;
}

Fit fit_runs(const std::vector<const Run*>& runs, const std::vector<Effect>& effects,
             const MfParams& start) {
  return fit_runs_from(runs, effects, {start.B, start.C, start.D, start.E});
}

Fit fit_runs_from(const std::vector<const Run*>& runs, const std::vector<Effect>& effects,
                  const std::vector<double>& x0_head) {
  const auto np = static_cast<Eigen::Index>(param_count(effects));
  double peak = 0;
  for (const Run* r : runs)
    for (double f : r->force_n) peak = std::max(peak, std::abs(f));
  Eigen::VectorXd lo(np), hi(np), x0(np);
  lo.head(4) << 0.1, 0.3, 0.0, -20.0;
  hi.head(4) << 200.0, 3.0, 5.0 * peak, 1.0;
  Eigen::Index i = 4;
  for (Effect e : effects)
    for (const EffectParam& ep : effect_params(e)) {
      const ParamRange r = param_range(e, ep, runs, peak, effects);
      lo(i) = r.lo;
      hi(i) = r.hi;
      x0(i++) = r.start;
    }
  // The given head (a curve, or a fit of the model's first effects), inside this model's ranges.
  for (Eigen::Index k = 0; k < std::min<Eigen::Index>(np, std::ssize(x0_head)); ++k)
    x0(k) = std::clamp(x0_head[static_cast<std::size_t>(k)], lo(k), hi(k));
  GapProblem problem(runs, effects);
  fit::LmOptions lm;
  lm.max_iterations = 100;
  const fit::LmResult r = fit::minimize(problem, x0, lo, hi, lm);
  Fit out;
  out.params.assign(r.x.data(), r.x.data() + r.x.size());
  out.stderr_ = gap_standard_errors(r, effects, 4);
  out.ssr = r.ssr;
  out.points = static_cast<std::size_t>(problem.residual_count());
  return out;
}

Fit fit_effects(const std::vector<const Run*>& runs, const std::vector<Effect>& effects,
                const MfParams& base) {
  const std::vector<double> b{base.B, base.C, base.D, base.E};
  Fit out;
  out.params = b;
  out.stderr_.assign(4, NAN);
  std::size_t n = 0;
  for (const Run* r : runs) n += r->fitted_points();
  out.points = n;
  if (effects.empty()) {
    for (const Run* r : runs) {
      const auto f = predict(*r, b, {});
      for (std::size_t i = 0; i < f.size(); ++i)
        if (r->fitted_at(i)) out.ssr += (f[i] - r->force_n[i]) * (f[i] - r->force_n[i]);
    }
    return out;
  }
  const auto np = static_cast<Eigen::Index>(param_count(effects) - 4);
  Eigen::VectorXd lo(np), hi(np), x0(np);
  Eigen::Index i = 0;
  double peak = 0;
  for (const Run* r : runs)
    for (double f : r->force_n) peak = std::max(peak, std::abs(f));
  for (Effect e : effects)
    for (const EffectParam& ep : effect_params(e)) {
      const ParamRange r = param_range(e, ep, runs, peak, effects);
      lo(i) = r.lo;
      hi(i) = r.hi;
      x0(i++) = r.start;
    }
  GapProblem problem(runs, effects, b);
  fit::LmOptions lm;
  lm.max_iterations = 100;
  const fit::LmResult r = fit::minimize(problem, x0, lo, hi, lm);
  out.params.insert(out.params.end(), r.x.data(), r.x.data() + r.x.size());
  const std::vector<double> errors = gap_standard_errors(r, effects, 0);
  out.stderr_.insert(out.stderr_.end(), errors.begin(), errors.end());
  out.ssr = r.ssr;
  return out;
}

std::size_t Run::fitted_points() const {
  return fit_mask.empty()
             ? t_s.size()
             : static_cast<std::size_t>(std::count_if(fit_mask.begin(), fit_mask.end(),
                                                      [](std::uint8_t m) { return m != 0; }));
}

std::vector<const Run*> pointers(const std::vector<Run>& runs) {
  std::vector<const Run*> out;
  out.reserve(runs.size());
  for (const Run& r : runs) out.push_back(&r);
  return out;
}

double rmse(const Run& r, const std::vector<double>& params, const std::vector<Effect>& effects) {
  const auto f = predict(r, params, effects);
  double s = 0;
  for (std::size_t i = 0; i < f.size(); ++i) s += (f[i] - r.force_n[i]) * (f[i] - r.force_n[i]);
  return std::sqrt(s / static_cast<double>(f.size()));
}

}  // namespace brakefit::gap
