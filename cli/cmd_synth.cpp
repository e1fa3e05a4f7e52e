#include <fmt/format.h>

#include <iostream>

#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "core/curve_csv.hpp"
#include "core/rng.hpp"

namespace brakefit::cli {

void add_synth_command(CLI::App& app) {
  struct Opts {
    MfParams p{15.0, 1.6, 4000.0, 0.3, 0.0, 0.0};
    double slip_max = 1.0, noise = 0.0;
    std::size_t points = 200;
    std::uint64_t seed = 1;
    std::string out, unit = "ratio";
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "synth", "Write a Magic Formula curve (with optional Gaussian noise) as CSV");
  cmd->add_option("--B", o->p.B, "stiffness factor per unit slip ratio")->capture_default_str();
  cmd->add_option("--C", o->p.C, "shape factor")->capture_default_str();
  cmd->add_option("--D", o->p.D, "peak factor [N]")->capture_default_str();
  cmd->add_option("--E", o->p.E, "curvature factor")->capture_default_str();
  cmd->add_option("--slip-max", o->slip_max, "last slip ratio (a roller test stops at 0.27)")
      ->check(CLI::Range(0.01, 1.0))
      ->capture_default_str();
  cmd->add_option("--points", o->points, "number of points")
      ->check(CLI::Range(8, 1000000))
      ->capture_default_str();
  cmd->add_option("--noise", o->noise, "noise sigma as a fraction of D")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "noise seed")->capture_default_str();
  cmd->add_option("--slip-unit", o->unit, "slip column: ratio (slip) or percent (slip_pct)")
      ->check(CLI::IsMember({"ratio", "percent"}))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "CSV file (default: stdout)");
  cmd->callback([o] {
    Curve c = sample_curve(o->p, even_slips(o->points, o->slip_max));
    Rng rng(o->seed);
    for (double& f : c.force_n) f += o->noise * o->p.D * rng.normal();
    std::string text = fmt::format("# brakefit synth: B={} C={} D={} E={} noise={} seed={}\n",
                                   o->p.B, o->p.C, o->p.D, o->p.E, o->noise, o->seed);
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
