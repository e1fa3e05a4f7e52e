#include <fmt/format.h>

#include <cmath>
#include <iostream>

#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "core/curve_csv.hpp"
#include "core/rng.hpp"
#include "sim/second/tir.hpp"
#include "sim/second/tyre.hpp"

namespace brakefit::cli {

void add_synth_command(CLI::App& app) {
  struct Opts {
    MfParams p{15.0, 1.6, 4000.0, 0.3, 0.0, 0.0};
    double slip_max = 1.0, noise = 0.0;
    std::size_t points = 200;
    std::uint64_t seed = 1;
    std::string out, unit = "ratio", tir;
    double wheel_load_n = NAN, pressure_bar = NAN, speed_kmh = 5.0;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "synth",
      "Write a Magic Formula curve (Pacejka-96 B, C, D, E, or an MF 6.1 .tir file at a load and "
      "pressure; optional Gaussian noise) as CSV");
  auto* opt_b =
      cmd->add_option("--B", o->p.B, "stiffness factor per unit slip ratio")->capture_default_str();
  auto* opt_c = cmd->add_option("--C", o->p.C, "shape factor")->capture_default_str();
  auto* opt_d = cmd->add_option("--D", o->p.D, "peak factor [N]")->capture_default_str();
  auto* opt_e = cmd->add_option("--E", o->p.E, "curvature factor")->capture_default_str();
  auto* tir =
      cmd->add_option("--tir", o->tir,
                      "instead of B, C, D, E: an MF 6.1 tyre file's pure longitudinal force "
                      "(written with # wheel_load_n= and # tyre_pressure_bar= lines)")
          ->excludes(opt_b, opt_c, opt_d, opt_e);
  cmd->add_option("--wheel-load-n", o->wheel_load_n, "with --tir: wheel load (default FNOMIN)")
      ->needs(tir);
  cmd->add_option("--tyre-pressure-bar", o->pressure_bar,
                  "with --tir: inflation pressure (default NOMPRES)")
      ->needs(tir);
  cmd->add_option("--speed-kmh", o->speed_kmh, "with --tir: the wheel's speed")
      ->needs(tir)
      ->capture_default_str();
  cmd->add_option("--slip-max", o->slip_max, "last slip ratio (a roller test stops at 0.27)")
      ->check(CLI::Range(0.01, 1.0))
      ->capture_default_str();
  cmd->add_option("--points", o->points, "number of points")
      ->check(CLI::Range(8, 1000000))
      ->capture_default_str();
  cmd->add_option("--noise", o->noise, "noise sigma as a fraction of D (of the peak with --tir)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "noise seed")->capture_default_str();
  cmd->add_option("--slip-unit", o->unit, "slip column: ratio (slip) or percent (slip_pct)")
      ->check(CLI::IsMember({"ratio", "percent"}))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "CSV file (default: stdout)");
  cmd->callback([o] {
    Curve c;
    std::string text;
    double scale_n = o->p.D;
    if (o->tir.empty()) {
      c = sample_curve(o->p, even_slips(o->points, o->slip_max));
      text = fmt::format("# brakefit synth: B={} C={} D={} E={} noise={} seed={}\n", o->p.B, o->p.C,
                         o->p.D, o->p.E, o->noise, o->seed);
    } else {
      const sim2::Mf61Longitudinal t =
          sim2::mf61_from_tir(sim2::parse_tir(read_file(o->tir), o->tir), o->tir);
      sim2::Contact k;
      k.fz_n = std::isnan(o->wheel_load_n) ? t.fnomin_n : o->wheel_load_n;
      k.pressure_pa = std::isnan(o->pressure_bar) ? t.nompres_pa : o->pressure_bar * 1e5;
      k.slip_speed_mps = 0;
      c.slip_ratio = even_slips(o->points, o->slip_max);
      for (double s : c.slip_ratio) c.force_n.push_back(sim2::mf61_braking_force_n(t, s, k));
      scale_n = c.peak_abs_force_n();
      text = fmt::format(
          "# brakefit synth: MF 6.1 {} noise={} seed={}\n# wheel_load_n={}\n# "
          "tyre_pressure_bar={}\n# speed_kmh={}\n",
          o->tir, o->noise, o->seed, k.fz_n, k.pressure_pa / 1e5, o->speed_kmh);
    }
    Rng rng(o->seed);
    for (double& f : c.force_n) f += o->noise * scale_n * rng.normal();
    const bool pct = o->unit == "percent";
    text += pct ? "slip_pct,force_n\n" : "slip,force_n\n";
    for (std::size_t i = 0; i < c.size(); ++i)
      text += fmt::format("{:.6f},{:.3f}\n", pct ? c.slip_ratio[i] * 100.0 : c.slip_ratio[i],
                          c.force_n[i]);
    if (o->out.empty())
      std::cout << text;
    else
      write_file(o->out, text);
  });
}

}  // namespace brakefit::cli
