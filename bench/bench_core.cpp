// Google Benchmark: BMU lookup, one LM fit, one hybrid fit (200 points), SOM training in the
// paper's configuration (10x10 hex, batch, 1000 rough + 500 fine epochs, 2000 curves), MLP
// training, and the Magic Formula over a run's 4096 samples one at a time against in vector stages
// (core/vecmath.hpp, as the gap diagnosis evaluates it).
#include <benchmark/benchmark.h>

#include "cli/io.hpp"
#include "core/rng.hpp"
#include "core/train.hpp"
#include "core/vecmath.hpp"

using namespace brakefit;

namespace {

const Model& shipped_model() {
  static const Model m = cli::load_model(cli::resolve_model_path(""));
  return m;
}

Curve test_curve(std::size_t points = 200) {
  Rng rng(99);
  const MfParams truth{14.0, 1.6, 4200.0, 0.25, 0, 0};
  Curve c = sample_curve(truth, even_slips(points, 1.0));
  for (double& f : c.force_n) f += 0.01 * truth.D * rng.normal();
  return c;
}

void BM_BmuLookup(benchmark::State& st) {
  const Model& m = shipped_model();
  const GridCurve g = resample_to_grid(test_curve(), m.grid);
  for (auto _ : st) benchmark::DoNotOptimize(m.som.bmu_masked(g.values, g.mask, true));
}
BENCHMARK(BM_BmuLookup);

void BM_LmFit200(benchmark::State& st) {
  const Curve c = test_curve();
  for (auto _ : st) benchmark::DoNotOptimize(fit::fit_mf(c, fit::classic_start(c)));
}
BENCHMARK(BM_LmFit200)->Unit(benchmark::kMicrosecond);

const MfParams kRunTyre{14.0, 1.6, 4200.0, 0.25, 0, 0};
std::vector<double> run_slips() {
  return even_slips(4096, 0.4);
}

void BM_MfScalar4096(benchmark::State& st) {
  const std::vector<double> slip = run_slips();
  std::vector<double> f(slip.size());
  for (auto _ : st) {
    for (std::size_t i = 0; i < slip.size(); ++i) f[i] = mf_force_n(kRunTyre, slip[i]);
    benchmark::DoNotOptimize(f.data());
  }
}
BENCHMARK(BM_MfScalar4096)->Unit(benchmark::kMicrosecond);

void BM_MfVector4096(benchmark::State& st) {
  const std::vector<double> slip = run_slips();
  const MfParams& p = kRunTyre;
  std::vector<double> u(slip.size()), f(slip.size());
  for (auto _ : st) {
    for (std::size_t i = 0; i < slip.size(); ++i) u[i] = f[i] = p.B * slip[i];
    atan_in_place(f);
    for (std::size_t i = 0; i < slip.size(); ++i) f[i] = u[i] - p.E * (u[i] - f[i]);
    atan_in_place(f);
    for (double& x : f) x *= p.C;
    sin_in_place(f);
    for (double& x : f) x *= p.D;
    benchmark::DoNotOptimize(f.data());
  }
  st.SetLabel(vector_math_available() ? "libmvec AVX2" : "scalar (no AVX2 on this CPU)");
}
BENCHMARK(BM_MfVector4096)->Unit(benchmark::kMicrosecond);

void BM_HybridFit200(benchmark::State& st) {
  const Model& m = shipped_model();
  const Curve c = test_curve();
  for (auto _ : st) benchmark::DoNotOptimize(run_method(Method::Hybrid, &m, c));
}
BENCHMARK(BM_HybridFit200)
    ->Unit(benchmark::kMicrosecond)
    ->ComputeStatistics("p50", [](const std::vector<double>& v) {
      std::vector<double> s = v;
      std::sort(s.begin(), s.end());
      return s[s.size() / 2];
    });

void BM_SomTrainPaper(benchmark::State& st) {
  TrainConfig c;  // defaults: 10x10 hex, batch, 1000 + 500 epochs, 2000 curves
  for (auto _ : st) benchmark::DoNotOptimize(train_som_only(c));
}
BENCHMARK(BM_SomTrainPaper)->Unit(benchmark::kSecond)->Iterations(1);

void BM_MlpTrain(benchmark::State& st) {
  TrainConfig c;
  c.som.rough.epochs = 0;
  c.som.fine.epochs = 0;
  c.mlp.max_epochs = static_cast<std::size_t>(st.range(0));
  c.mlp.patience = c.mlp.max_epochs;
  for (auto _ : st) benchmark::DoNotOptimize(train_model(c));
  st.SetLabel("2000 curves, 49-32-32-3, rprop");
}
BENCHMARK(BM_MlpTrain)->Arg(300)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
