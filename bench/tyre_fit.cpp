// bench/tyre_fit: the MF 6.1 fit (brakefit tyre) on tyres it never saw. Each tyre's coefficients
// are drawn at random from published passenger-car and van ranges (not from the project's files);
// its curves come from the second simulator's MF 6.1 evaluator (code the fit shares nothing with),
// with 1 % Gaussian noise. The written .tir is read back by the second simulator's reader and
// compared with the truth over slip 0..1:
//   - lab: three loads (0.6, 1.0, 1.4 FNOMIN) x two pressures, slip to 1.0 (targets: 2 % of the
//     peak at the fitted loads, 4 % at loads 0.5..1.5 FNOMIN between and beyond them);
//   - roller: the same loads and pressures, slip to 0.27 only (which coefficients it holds);
//   - speed: 12 curves of 2 000 points (a 1 kHz event's) on one core, against 12 Pacejka-96 fits
//     of the same curves measured in the same run.
// Usage: tyre_fit [--tyres N] [--seed S] [--out FILE]   (markdown to stdout and FILE)
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "core/fit/mf_fit.hpp"
#include "core/tyre/mf61_fit.hpp"
#include "core/tyre/tir_writer.hpp"
#include "sim/second/tir.hpp"
#include "sim/second/tyre.hpp"

namespace {

using namespace brakefit;
using sim2::Mf61Longitudinal;

Mf61Longitudinal random_tyre(std::mt19937_64& rng, int i) {
  auto u = [&](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  Mf61Longitudinal t;
  t.name = fmt::format("random-{}", i);
  t.fnomin_n = u(3000, 8000);
  t.nompres_pa = u(1.8e5, 4.5e5);
  t.pcx1 = u(1.4, 1.8);
  t.pdx1 = u(0.8, 1.3);
  t.pdx2 = u(-0.15, 0.0);
  t.pex1 = u(-0.5, 0.6);
  t.pex2 = u(-0.3, 0.4);
  t.pex3 = u(-0.2, 0.1);
  t.pex4 = u(-0.1, 0.1);
  t.pkx1 = u(15, 30);
  t.pkx2 = u(0, 15);
  t.pkx3 = u(-0.6, 0.1);
  t.phx1 = u(-5e-4, 5e-4);
  t.phx2 = u(-1e-3, 1e-3);
  t.pvx1 = u(-1e-4, 1e-4);
  t.pvx2 = u(-1e-4, 1e-4);
  t.ppx1 = u(-0.5, -0.1);
  t.ppx2 = u(0.0, 0.5);
  t.ppx3 = u(-0.15, 0.0);
  t.ppx4 = u(0.0, 0.1);
  return t;
}

std::vector<tyre::TyreCurve> draw(const Mf61Longitudinal& t, double slip_max, int points,
                                  const std::vector<double>& speeds_kmh, std::mt19937_64& rng) {
  std::normal_distribution<double> n01;
  std::vector<tyre::TyreCurve> out;
  for (double l : {0.6, 1.0, 1.4})
    for (double p : {1.0, 1.2})
      for (double v : speeds_kmh) {
        sim2::Contact c;
        c.fz_n = l * t.fnomin_n;
        c.pressure_pa = p * t.nompres_pa;
        tyre::TyreCurve tc;
        tc.source = fmt::format("Fz {:.1f} p {:.1f} v {:g}", l, p, v);
        tc.op = {c.fz_n, c.pressure_pa, v / 3.6};
        double peak = 0;
        for (int k = 1; k <= points; ++k) {
          const double s = slip_max * k / points;
          tc.curve.slip_ratio.push_back(s);
          tc.curve.force_n.push_back(sim2::mf61_braking_force_n(t, s, c));
          peak = std::max(peak, tc.curve.force_n.back());
        }
        for (auto& f : tc.curve.force_n) f += 0.01 * peak * n01(rng);
        out.push_back(std::move(tc));
      }
  return out;
}

double rms_pct(const Mf61Longitudinal& truth, const Mf61Longitudinal& file, double fz, double p,
               double slip_max = 1.0) {
  sim2::Contact c;
  c.fz_n = fz;
  c.pressure_pa = p;
  double ss = 0, peak = 0;
  for (int k = 0; k <= 400; ++k) {
    const double s = slip_max * k / 400.0;
    const double a = sim2::mf61_braking_force_n(truth, s, c);
    const double b = sim2::mf61_braking_force_n(file, s, c);
    ss += (a - b) * (a - b);
    peak = std::max(peak, a);
  }
  return 100 * std::sqrt(ss / 401) / peak;
}

struct Scores {
  double fitted = 0, between = 0;
};

Scores score(const Mf61Longitudinal& truth, const Mf61Longitudinal& file, double slip_max = 1.0) {
  Scores s;
  for (double p : {1.0, 1.2}) {
    for (double l : {0.6, 1.0, 1.4})
      s.fitted = std::max(s.fitted,
                          rms_pct(truth, file, l * truth.fnomin_n, p * truth.nompres_pa, slip_max));
    for (double l = 0.5; l <= 1.501; l += 0.05)
      s.between =
          std::max(s.between, rms_pct(truth, file, l * truth.fnomin_n, p * truth.nompres_pa));
  }
  return s;
}

Mf61Longitudinal written(const tyre::Mf61FitResult& fit) {
  const std::string text = tyre::format_tir(fit, {"bench", "", "", {}, 0.3, ""});
  return sim2::mf61_from_tir(sim2::parse_tir(text, "written.tir"), "written");
}

double quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

std::string commit() {
  std::string out;
  if (FILE* p = popen("git -C " BRAKEFIT_SOURCE_DIR " rev-parse --short HEAD 2>/dev/null", "r")) {
    char buf[64];
    while (fgets(buf, sizeof buf, p)) out += buf;
    pclose(p);
  }
  while (!out.empty() && out.back() == '\n') out.pop_back();
  return out.empty() ? "unknown" : out;
}

}  // namespace

int main(int argc, char** argv) {
  int tyres = 50;
  unsigned seed = 2026;
  std::string out_file;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--tyres")
      tyres = std::stoi(argv[i + 1]);
    else if (a == "--seed")
      seed = static_cast<unsigned>(std::stoul(argv[i + 1]));
    else if (a == "--out")
      out_file = argv[i + 1];
    else {
      std::fprintf(stderr, "usage: tyre_fit [--tyres N] [--seed S] [--out FILE]\n");
      return 64;
    }
  }
  std::mt19937_64 rng(seed);
  std::vector<double> lab_fitted, lab_between, roller_measured, roller_full;
  int lab_pass = 0;
  std::map<std::string, int> roller_held;
  std::vector<double> t_mf61, t_pac96;
  for (int i = 0; i < tyres; ++i) {
    const Mf61Longitudinal truth = random_tyre(rng, i);
    {
      const auto curves = draw(truth, 1.0, 200, {5.0}, rng);
      const auto fit = tyre::fit_mf61(curves);
      const Scores s = score(truth, written(fit));
      lab_fitted.push_back(s.fitted);
      lab_between.push_back(s.between);
      if (s.fitted < 2.0 && s.between < 4.0) ++lab_pass;
    }
    {
      const auto curves = draw(truth, 0.27, 200, {5.0}, rng);
      const auto fit = tyre::fit_mf61(curves);
      const Mf61Longitudinal file = written(fit);
      roller_measured.push_back(score(truth, file, 0.27).fitted);
      roller_full.push_back(score(truth, file).fitted);
      for (const auto& h : fit.held)
        if (h.reason.starts_with("not identified") || h.reason.starts_with("no curve"))
          ++roller_held[std::string(tyre::coef_name(h.index))];
    }
    if (i < 10) {
      const auto curves = draw(truth, 1.0, 2000, {5.0, 10.0}, rng);
      auto t0 = std::chrono::steady_clock::now();
      const auto fit = tyre::fit_mf61(curves);
      t_mf61.push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      t0 = std::chrono::steady_clock::now();
      for (const auto& c : curves) (void)fit::fit_mf(c.curve, fit::classic_start(c.curve));
      t_pac96.push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    if ((i + 1) % 10 == 0 || i + 1 == tyres) std::fprintf(stderr, "tyre %d/%d\n", i + 1, tyres);
  }
  std::string md = fmt::format(
      "<!-- written by `build/release/bench/tyre_fit --tyres {} --seed {}` at commit {} -->\n\n",
      tyres, seed, commit());
  md += fmt::format(
      "{} random MF 6.1 tyres; curves at 0.6, 1.0, 1.4 FNOMIN x NOMPRES, 1.2 NOMPRES, 1 % noise, "
      "200 points each. Figures: RMS of (written file - truth) over slip 0..1, % of the truth's "
      "peak; the worst load and pressure of each tyre.\n\n",
      tyres);
  md += "| case | median | 95th pct | worst | target |\n|---|---|---|---|---|\n";
  md +=
      fmt::format("| slip to 1.0, fitted loads | {:.2f} | {:.2f} | {:.2f} | 2 % |\n",
                  quantile(lab_fitted, 0.5), quantile(lab_fitted, 0.95), quantile(lab_fitted, 1.0));
  md += fmt::format("| slip to 1.0, loads 0.5..1.5 FNOMIN | {:.2f} | {:.2f} | {:.2f} | 4 % |\n",
                    quantile(lab_between, 0.5), quantile(lab_between, 0.95),
                    quantile(lab_between, 1.0));
  md += fmt::format(
      "| slip to 0.27, fitted loads, over slip 0..0.27 | {:.2f} | {:.2f} | {:.2f} | |\n",
      quantile(roller_measured, 0.5), quantile(roller_measured, 0.95),
      quantile(roller_measured, 1.0));
  md += fmt::format(
      "| slip to 0.27, over slip 0..1 (the tail unmeasured), fitted loads | {:.2f} | {:.2f} | "
      "{:.2f} | |\n\n",
      quantile(roller_full, 0.5), quantile(roller_full, 0.95), quantile(roller_full, 1.0));
  md += fmt::format("Within both targets: {} of {} tyres.\n\n", lab_pass, tyres);
  md += "At slip to 0.27, held as not identified (tyres of " + std::to_string(tyres) + "): ";
  std::string held;
  for (const auto& [name, n] : roller_held)
    held += fmt::format("{}{} {}", held.empty() ? "" : ", ", name, n);
  md += (held.empty() ? "none" : held) + ".\n\n";
  md += fmt::format(
      "Speed, one core: 12 curves of 2 000 points (3 loads x 2 pressures x 2 speeds): MF 6.1 joint "
      "fit median {:.3f} s (worst {:.3f} s, target 2 s); 12 Pacejka-96 fits of the same curves "
      "{:.3f} s; ratio {:.1f}.\n",
      quantile(t_mf61, 0.5), quantile(t_mf61, 1.0), quantile(t_pac96, 0.5),
      quantile(t_mf61, 0.5) / quantile(t_pac96, 0.5));
  std::fputs(md.c_str(), stdout);
  if (!out_file.empty()) std::ofstream(out_file) << md;
  return 0;
}
