#include "core/tyre/tir_writer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace brakefit::tyre {

namespace {

std::string quoted(std::string s) {
  // A quote inside a .tir string ends it: the file's readers know no escape.
  std::replace(s.begin(), s.end(), '\'', '"');
  return "'" + s + "'";
}

/// A '!' comment line per line of text (a reader stops a comment at the line's end).
void comment(std::string& out, const std::string& text) {
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t nl = std::min(text.find('\n', pos), text.size());
    out += "! " + text.substr(pos, nl - pos) + "\n";
    pos = nl + 1;
  }
}

void key(std::string& out, const std::string& name, double value, const std::string& note = {}) {
  out += fmt::format("{:<22}= {:<16.9g}", name, value);
  if (!note.empty()) out += "$ " + note;
  // A trailing blank after the value is harmless to readers, but keep lines tidy.
  while (!out.empty() && out.back() == ' ') out.pop_back();
  out += "\n";
}

void text_key(std::string& out, const std::string& name, const std::string& value) {
  out += fmt::format("{:<22}= {}\n", name, quoted(value));
}

}  // namespace

std::string format_tir(const Mf61FitResult& fit, const TirProvenance& prov,
                       const std::optional<ScalingFit>& scalings) {
  const Mf61Reference& ref = fit.tyre.ref;
  std::string out;
  out += "[MDI_HEADER]\n";
  text_key(out, "FILE_TYPE", "tir");
  key(out, "FILE_VERSION", 3.0);
  text_key(out, "FILE_FORMAT", "ASCII");
  comment(out,
          fmt::format("MF 6.1 pure longitudinal force fitted by brakefit {} (model hash {})",
                      prov.brakefit_version, prov.model_hash.empty() ? "none" : prov.model_hash));
  if (!prov.tyre_name.empty()) comment(out, "tyre: " + prov.tyre_name);
  if (!prov.created.empty()) comment(out, "created: " + prov.created);
  comment(out,
          "sign convention ISO 8855 / TYDEX: a braking wheel has longitudinal slip kappa < 0 and "
          "force Fx < 0");
  comment(out,
          fmt::format("{} curves at {} wheel load(s), {} inflation pressure(s), {} speed(s); "
                      "joint fit RMS {:.2f} % of each curve's peak",
                      fit.curves.size(), fit.loads, fit.pressures, fit.speeds, fit.rms_pct_peak));
  for (const auto& r : prov.runs) comment(out, "input: " + r);
  for (const auto& c : fit.curves)
    comment(out, fmt::format("curve {}: Fz {:.0f} N, p {:.0f} Pa, V {:.2f} m/s, slip to {:.3f}, "
                             "{} points, RMS {:.2f} % of peak",
                             c.source, c.op.fz_n, c.op.pressure_pa, c.op.speed_mps,
                             c.max_slip_ratio, c.points, c.rms_pct_peak));
  comment(out,
          "Only the pure longitudinal force is fitted: the lateral, aligning, overturning, "
          "rolling resistance and vertical coefficients are absent (0), not measured.");
  if (!fit.held.empty()) {
    comment(out, "Held at a stated default (the curves could not identify them):");
    for (const auto& h : fit.held)
      comment(out, fmt::format("  {} = {:g}: {}", coef_name(h.index), h.value, h.reason));
  }
  if (!fit.at_bound.empty()) {
    std::string names;
    for (const auto& n : fit.at_bound) names += (names.empty() ? "" : ", ") + n;
    comment(out,
            "Ended on the edge of its plausible range (the range, not the data, set it): " + names);
  }

  out += "[UNITS]\n";
  text_key(out, "LENGTH", "meter");
  text_key(out, "FORCE", "newton");
  text_key(out, "ANGLE", "radian");
  text_key(out, "MASS", "kg");
  text_key(out, "TIME", "second");

  out += "[MODEL]\n";
  key(out, "FITTYP", 61, "Magic Formula 6.1");
  text_key(out, "TYRESIDE", "LEFT");
  key(out, "LONGVL", ref.longvl_mps, "reference speed, m/s");
  key(out, "VXLOW", 1.0);

  out += "[DIMENSION]\n";
  if (std::isfinite(prov.rolling_radius_m))
    key(out, "UNLOADED_RADIUS", prov.rolling_radius_m,
        "the rolling radius the slips were computed with, m");
  else
    comment(out, "UNLOADED_RADIUS unknown: the curves came with slip already computed");

  out += "[OPERATING_CONDITIONS]\n";
  key(out, "INFLPRES", ref.nompres_pa, "Pa");
  key(out, "NOMPRES", ref.nompres_pa, "Pa, the pressure laws' reference");

  out += "[VERTICAL]\n";
  key(out, "FNOMIN", ref.fnomin_n, "N, the load laws' reference");

  double max_slip = 0, fz_lo = INFINITY, fz_hi = 0;
  for (const auto& c : fit.curves) {
    max_slip = std::max(max_slip, c.max_slip_ratio);
    fz_lo = std::min(fz_lo, c.op.fz_n);
    fz_hi = std::max(fz_hi, c.op.fz_n);
  }
  out += "[LONG_SLIP_RANGE]\n";
  key(out, "KPUMIN", -max_slip, "the largest braking slip measured");
  key(out, "KPUMAX", 0.0, "only braking slip was measured");
  out += "[VERTICAL_FORCE_RANGE]\n";
  key(out, "FZMIN", fz_lo, "N, the lightest load measured");
  key(out, "FZMAX", fz_hi, "N, the heaviest load measured");

  out += "[SCALING_COEFFICIENTS]\n";
  auto scale = [&](const char* name) -> std::pair<double, std::string> {
    if (!scalings) return {1.0, {}};
    for (std::size_t i = 0; i < kScalingNames.size(); ++i) {
      if (name != std::string(kScalingNames[i])) continue;
      if (!scalings->held_reason[i].empty()) return {1.0, "held: " + scalings->held_reason[i]};
      return {scalings->value[i],
              fmt::format("rig relative to the file, standard error {:.3g}", scalings->stderr_[i])};
    }
    return {1.0, {}};
  };
  for (const char* n : {"LFZO", "LCX", "LMUX", "LEX", "LKX", "LHX", "LVX"}) {
    const auto [v, note] = scale(n);
    key(out, n, v, note);
  }
  const std::size_t lmuv = static_cast<std::size_t>(Coef::LMUV);
  const std::string lmuv_held = fit.held_reason(lmuv);
  key(out, "LMUV", fit.tyre.coef[lmuv],
      lmuv_held.empty() ? fmt::format("fitted, standard error {:.3g}", fit.stderr_[lmuv])
                        : "held: " + lmuv_held);

  out += "[LONGITUDINAL_COEFFICIENTS]\n";
  for (std::size_t i = 0; i < kCoefCount; ++i) {
    if (i == lmuv) continue;
    const std::string why = fit.held_reason(i);
    key(out, std::string(coef_name(i)), fit.tyre.coef[i],
        why.empty() ? fmt::format("fitted, standard error {:.3g}", fit.stderr_[i])
                    : "held: " + why);
  }
  key(out, "PDX3", 0.0, "camber: not measured");
  return out;
}

}  // namespace brakefit::tyre
