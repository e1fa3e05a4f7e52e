// Reproduces the paper's comparison on curves NOT in the training database: MAPE, RMSE and
// parameter errors for som, mlp, lm (fixed start) and hybrid; on noisy curves the noise floor and
// the convergence rate of LM from random starts vs hybrid. Prints Markdown tables.
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <map>

#include "brakefit/version.hpp"
#include "cli/io.hpp"
#include "core/rng.hpp"
#include "core/train.hpp"

using namespace brakefit;

namespace {

struct TestCurve {
  MfParams truth;
  Curve clean;
  Curve measured;
};

double quantile(std::vector<double> v, double q) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  const double f = pos - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

std::vector<TestCurve> make_set(const DatabaseSettings& db, std::uint64_t seed, std::size_t n,
                                std::size_t points, double slip_max, double noise_frac) {
  Rng rng(seed);
  std::vector<TestCurve> out;
  const auto slips = even_slips(points, slip_max);
  for (std::size_t i = 0; i < n; ++i) {
    TestCurve t;
    t.truth = draw_params(db, rng);
    t.clean = sample_curve(t.truth, slips);
    t.measured = t.clean;
    const double sigma = noise_frac * t.clean.peak_abs_force_n();
    for (double& f : t.measured.force_n) f += sigma * rng.normal();
    out.push_back(std::move(t));
  }
  return out;
}

struct MethodStats {
  std::vector<double> mape, rmse_pct, dB, dC, dD, dE, dpeak_f, dpeak_s, rmse_n, micros;
};

void add(MethodStats& s, const TestCurve& t, const MethodResult& r, double micros) {
  s.mape.push_back(r.metrics.mape_pct);
  s.rmse_pct.push_back(r.metrics.rmse_pct_peak);
  s.rmse_n.push_back(r.metrics.rmse_n);
  s.dB.push_back(100 * std::abs(r.params.B - t.truth.B) / t.truth.B);
  s.dC.push_back(100 * std::abs(r.params.C - t.truth.C) / t.truth.C);
  s.dD.push_back(100 * std::abs(r.params.D - t.truth.D) / t.truth.D);
  s.dE.push_back(std::abs(r.params.E - t.truth.E));
  const double smax = t.clean.max_slip_ratio();
  const MfPeak pt = mf_peak(t.truth, smax), pr = mf_peak(r.params, smax);
  s.dpeak_f.push_back(100 * std::abs(pr.force_n - pt.force_n) / pt.force_n);
  s.dpeak_s.push_back(std::abs(pr.slip_ratio - pt.slip_ratio) * 100);
  s.micros.push_back(micros);
}

void print_table(const std::string& title, const std::vector<Method>& methods,
                 std::map<Method, MethodStats>& st) {
  std::cout << "\n### " << title << "\n\n";
  std::cout << "| method | MAPE median % | MAPE p90 % | RMSE median % of peak | RMSE p90 % of peak "
               "| |dB| median % | "
               "|dC| median % | |dD| median % | |dE| median | peak force err median % | peak slip "
               "err median (pp) | time "
               "median µs |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (Method m : methods) {
    auto& s = st[m];
    std::cout << fmt::format(
        "| {} | {:.3f} | {:.3f} | {:.3f} | {:.3f} | {:.2f} | {:.2f} | {:.2f} | {:.3f} | {:.2f} | "
        "{:.2f} | {:.0f} |\n",
        to_string(m), quantile(s.mape, 0.5), quantile(s.mape, 0.9), quantile(s.rmse_pct, 0.5),
        quantile(s.rmse_pct, 0.9), quantile(s.dB, 0.5), quantile(s.dC, 0.5), quantile(s.dD, 0.5),
        quantile(s.dE, 0.5), quantile(s.dpeak_f, 0.5), quantile(s.dpeak_s, 0.5),
        quantile(s.micros, 0.5));
  }
}

std::map<Method, MethodStats> evaluate(const Model& model, const std::vector<TestCurve>& set,
                                       const std::vector<Method>& methods,
                                       const std::string& label) {
  std::map<Method, MethodStats> st;
  for (std::size_t i = 0; i < set.size(); ++i) {
    for (Method m : methods) {
      const auto t0 = std::chrono::steady_clock::now();
      const MethodResult r = run_method(m, &model, set[i].measured);
      const double us =
          std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
      add(st[m], set[i], r, us);
    }
    if ((i + 1) % std::max<std::size_t>(1, set.size() / 5) == 0)
      spdlog::info("{}: {}/{} curves", label, i + 1, set.size());
  }
  return st;
}

}  // namespace

namespace {

int run(int argc, char** argv) {
  spdlog::set_default_logger(
      spdlog::stderr_color_mt("accuracy"));  // tables on stdout, progress on stderr
  spdlog::set_pattern("[%H:%M:%S] %v");
  CLI::App app{"brakefit accuracy benchmark: the paper's comparison on withheld curves"};
  std::string model_path, config_path;
  std::size_t n = 300, points = 200, random_starts = 20;
  double noise = 0.01;
  std::uint64_t seed = 777;
  bool compare_input = false, compare_trainers = false;
  app.add_option("--model", model_path, "model (default: the shipped model)");
  app.add_option("--curves", n, "test curves per set")->capture_default_str();
  app.add_option("--points", points, "points per curve")->capture_default_str();
  app.add_option("--noise", noise, "noise sigma as a fraction of the peak")->capture_default_str();
  app.add_option("--random-starts", random_starts, "LM random starts per noisy curve")
      ->capture_default_str();
  app.add_option("--seed", seed, "seed of the test curves (disjoint from the database seed)")
      ->capture_default_str();
  app.add_flag("--compare-input", compare_input,
               "also train a raw-curve SOM and compare it with the shape SOM");
  app.add_flag("--compare-trainers", compare_trainers,
               "also train the MLP with gradient descent and Levenberg-Marquardt (paper Table 1)");
  CLI11_PARSE(app, argc, argv);

  try {
    const Model model = cli::load_model(cli::resolve_model_path(model_path));
    const DatabaseSettings& db = model.config.database;
    if (seed == db.seed) throw std::runtime_error("test seed must differ from the database seed");
    const std::vector<Method> methods{Method::Som, Method::Mlp, Method::Lm, Method::Hybrid};
    std::cout << fmt::format(
        "## brakefit {} accuracy on withheld curves\n\nmodel `{}` ({} database curves, seed {}; "
        "SOM "
        "{}x{} on {}; test seed {}), {} curves per set, {} points each.\n"
        "MAPE excludes points with |F| < 5 % of the measured peak.\n",
        kVersion, model.hash.substr(0, 23), db.n_curves, db.seed, model.som.lattice().rows(),
        model.som.lattice().cols(), to_string(model.config.som_input), seed, n, points);

    const auto full = make_set(db, seed, n, points, 1.0, 0.0);
    auto st_full = evaluate(model, full, methods, "noise-free 0-100 %");
    print_table("Noise-free, slip 0-100 % (flat-ground-like)", methods, st_full);

    const auto roller = make_set(db, seed + 1, n, points, 0.27, 0.0);
    auto st_roller = evaluate(model, roller, methods, "noise-free 0-27 %");
    print_table("Noise-free, slip 0-27 % (roller test switched off at 27 %)", methods, st_roller);

    const auto noisy = make_set(db, seed + 2, n, points, 1.0, noise);
    auto st_noisy = evaluate(model, noisy, methods, "noisy");
    print_table(fmt::format("Noisy (sigma = {:.1f} % of peak), slip 0-100 %", noise * 100), methods,
                st_noisy);

    // Noise floor, hybrid vs floor, convergence of LM from random starts vs hybrid.
    std::vector<double> floor_rmse_pct, floor_mape, ratio;
    std::size_t hybrid_within = 0, hybrid_conv = 0, lm_fixed_conv = 0, rs_conv = 0, rs_total = 0;
    Rng rng(seed + 3);
    for (std::size_t i = 0; i < noisy.size(); ++i) {
      const auto& t = noisy[i];
      const FitMetrics fm = compute_metrics(t.measured, t.truth);
      floor_rmse_pct.push_back(fm.rmse_pct_peak);
      floor_mape.push_back(fm.mape_pct);
      // Global optimum reference: LM started at the true parameters.
      const double best = fit::fit_mf(t.measured, t.truth).rmse_n;
      const double h = st_noisy[Method::Hybrid].rmse_n[i];
      ratio.push_back(h / fm.rmse_n);
      if (h <= 1.05 * fm.rmse_n) ++hybrid_within;
      if (h <= 1.01 * best) ++hybrid_conv;
      if (st_noisy[Method::Lm].rmse_n[i] <= 1.01 * best) ++lm_fixed_conv;
      const double peak = t.measured.peak_abs_force_n();
      for (std::size_t k = 0; k < random_starts; ++k) {
        const MfParams start{rng.uniform(1.0, 60.0),
                             rng.uniform(0.5, 2.5),
                             rng.uniform(0.2, 3.0) * peak,
                             rng.uniform(-10.0, 1.0),
                             0,
                             0};
        if (fit::fit_mf(t.measured, start).rmse_n <= 1.01 * best) ++rs_conv;
        ++rs_total;
      }
      if ((i + 1) % std::max<std::size_t>(1, noisy.size() / 5) == 0)
        spdlog::info("convergence: {}/{} curves", i + 1, noisy.size());
    }
    // Noise-free roller curves: the optimum is the truth (RMSE 0); reached = RMSE < 1e-6 of peak.
    std::size_t roller_lm = 0, roller_hybrid = 0;
    for (std::size_t i = 0; i < roller.size(); ++i) {
      roller_lm += st_roller[Method::Lm].rmse_pct[i] < 1e-4;
      roller_hybrid += st_roller[Method::Hybrid].rmse_pct[i] < 1e-4;
    }
    const double nn = static_cast<double>(noisy.size()), nr = static_cast<double>(roller.size());
    auto pct = [](std::size_t k, double total) { return 100.0 * static_cast<double>(k) / total; };
    std::cout << fmt::format(
        "\n### Noise floor and convergence\n\n"
        "| quantity | value |\n|---|---|\n"
        "| noise floor RMSE (true parameters on the noisy curves), median % of peak | {:.3f} |\n"
        "| noise floor MAPE (true parameters on the noisy curves), median % | {:.3f} |\n"
        "| hybrid RMSE / noise floor RMSE, median | {:.4f} |\n"
        "| hybrid RMSE / noise floor RMSE, max | {:.4f} |\n"
        "| noisy curves with hybrid RMSE <= 1.05 x noise floor (target >= 95 %) | {:.1f} % |\n"
        "| noisy: hybrid convergence (RMSE <= 1.01 x global optimum; target >= 99 %) | {:.1f} % |\n"
        "| noisy: lm from the fixed start (B=10, C=1.5, D=max, E=0) convergence | {:.1f} % |\n"
        "| noisy: lm from random starts convergence ({} starts per curve; B 1-60, C 0.5-2.5, D "
        "0.2-3 x peak, E -10..1) | {:.1f} % |\n"
        "| noise-free 0-27 %: hybrid reaches the true parameters | {:.1f} % |\n"
        "| noise-free 0-27 %: lm from the fixed start reaches the true parameters | {:.1f} % |\n",
        quantile(floor_rmse_pct, 0.5), quantile(floor_mape, 0.5), quantile(ratio, 0.5),
        *std::max_element(ratio.begin(), ratio.end()), pct(hybrid_within, nn), pct(hybrid_conv, nn),
        pct(lm_fixed_conv, nn), random_starts,
        pct(rs_conv, static_cast<double>(std::max<std::size_t>(1, rs_total))),
        pct(roller_hybrid, nr), pct(roller_lm, nr));

    if (compare_input) {
      TrainConfig raw_cfg = model.config;
      raw_cfg.som_input =
          model.config.som_input == SomInput::Shape ? SomInput::Raw : SomInput::Shape;
      spdlog::info("training a {} SOM for comparison", to_string(raw_cfg.som_input));
      Model other =
          train_som_only(raw_cfg, [](const std::string& st, std::size_t d, std::size_t tot,
                                     double l) { cli::log_progress(st, d, tot, l); });
      auto st_other = evaluate(other, full, {Method::Som}, "other SOM");
      auto st_other_r = evaluate(other, roller, {Method::Som}, "other SOM roller");
      std::cout << "\n### SOM input: peak-normalised shapes vs raw curves (noise-free)\n\n"
                   "| SOM input | qe | te | MAPE median % (0-100 %) | MAPE p90 % | MAPE median % "
                   "(0-27 %) | |dB| median % | |dD| median % |\n"
                   "|---|---|---|---|---|---|---|---|\n";
      auto row = [&](const Model& m, MethodStats& a, MethodStats& b) {
        std::cout << fmt::format(
            "| {} | {:.4f} | {:.4f} | {:.3f} | {:.3f} | {:.3f} | {:.2f} | {:.2f} |\n",
            to_string(m.config.som_input), m.som_qe, m.som_te, quantile(a.mape, 0.5),
            quantile(a.mape, 0.9), quantile(b.mape, 0.5), quantile(a.dB, 0.5), quantile(a.dD, 0.5));
      };
      row(model, st_full[Method::Som], st_roller[Method::Som]);
      row(other, st_other[Method::Som], st_other_r[Method::Som]);
      std::cout
          << "\n(qe is in the SOM's own input units: shapes are dimensionless, raw curves in N.)\n";
    }
    if (compare_trainers) {
      // Paper Table 1: the same task with each MLP trainer. LM needs a small network (its
      // Gauss-Newton matrix is parameters^2), so it gets one hidden layer of 16.
      std::cout << "\n### MLP trainers (paper Table 1), noise-free 0-100 % and 0-27 %\n\n"
                   "| trainer | hidden | epochs (best) | validation mse (scaled) | train s | MAPE "
                   "median % (0-100 %) | "
                   "MAPE p90 % | MAPE median % (0-27 %) |\n|---|---|---|---|---|---|---|---|\n";
      for (mlp::Trainer tr :
           {mlp::Trainer::Rprop, mlp::Trainer::GradientDescent, mlp::Trainer::LevenbergMarquardt}) {
        TrainConfig tc = model.config;
        tc.som.rough.epochs = 0;  // only the MLP is compared
        tc.som.fine.epochs = 0;
        tc.mlp.trainer = tr;
        tc.mlp_ensemble = 1;  // the paper's table compares one network's trainers
        if (tr == mlp::Trainer::LevenbergMarquardt) {
          tc.mlp.hidden = {16};
          tc.mlp.max_epochs = 150;
          tc.mlp.patience = 15;
        }
        if (tr == mlp::Trainer::GradientDescent) tc.mlp.learning_rate = 0.02;
        spdlog::info("training the MLP with {}", mlp::to_string(tr));
        const auto t0 = std::chrono::steady_clock::now();
        const Model m =
            train_model(tc, [](const std::string& st, std::size_t d, std::size_t tot, double l) {
              if (st == "mlp") cli::log_progress(st, d, tot, l);
            });
        const double secs =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        auto a = evaluate(m, full, {Method::Mlp}, "trainer full");
        auto b = evaluate(m, roller, {Method::Mlp}, "trainer roller");
        std::string hidden;
        for (std::size_t h : tc.mlp.hidden)
          hidden += (hidden.empty() ? "" : "-") + std::to_string(h);
        std::cout << fmt::format(
            "| {} | {} | {} ({}) | {:.4f} | {:.1f} | {:.3f} | {:.3f} | {:.3f} |\n",
            mlp::to_string(tr), hidden, m.mlp_report.front().epochs,
            m.mlp_report.front().best_epoch, m.mlp_report.front().validation_mse, secs,
            quantile(a[Method::Mlp].mape, 0.5), quantile(a[Method::Mlp].mape, 0.9),
            quantile(b[Method::Mlp].mape, 0.5));
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "accuracy: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "accuracy: error: " << e.what() << "\n";
    return 1;
  }
}
