#include "sim/second/tyre.hpp"

#include <algorithm>
#include <cmath>

namespace brakefit::sim2 {

Mf61Longitudinal mf61_from_tir(const TirFile& f, const std::string& name) {
  Mf61Longitudinal t;
  t.name = name;
  const std::string L = "LONGITUDINAL_COEFFICIENTS", S = "SCALING_COEFFICIENTS";
  t.fnomin_n = f.at("VERTICAL", "FNOMIN");
  t.nompres_pa = f.get("OPERATING_CONDITIONS", "NOMPRES", 2.2e5);
  t.longvl_mps = f.get("MODEL", "LONGVL", 16.7);
  t.iyy_kgm2 = f.get("INERTIA", "IYY", 1.0);
  t.lfzo = f.get(S, "LFZO", 1);
  t.lmux = f.get(S, "LMUX", 1);
  t.lkx = f.get(S, "LKX", 1);
  t.pcx1 = f.at(L, "PCX1");
  t.pdx1 = f.at(L, "PDX1");
  t.pkx1 = f.at(L, "PKX1");
  t.pdx2 = f.get(L, "PDX2", 0);
  t.pex1 = f.get(L, "PEX1", 0);
  t.pex2 = f.get(L, "PEX2", 0);
  t.pex3 = f.get(L, "PEX3", 0);
  t.pex4 = f.get(L, "PEX4", 0);
  t.pkx2 = f.get(L, "PKX2", 0);
  t.pkx3 = f.get(L, "PKX3", 0);
  t.phx1 = f.get(L, "PHX1", 0);
  t.phx2 = f.get(L, "PHX2", 0);
  t.pvx1 = f.get(L, "PVX1", 0);
  t.pvx2 = f.get(L, "PVX2", 0);
  t.ppx1 = f.get(L, "PPX1", 0);
  t.ppx2 = f.get(L, "PPX2", 0);
  t.ppx3 = f.get(L, "PPX3", 0);
  t.ppx4 = f.get(L, "PPX4", 0);
  return t;
}

namespace {

struct Mf61Terms {
  double bx, cx, dx, ex, shx, svx;
};

Mf61Terms terms(const Mf61Longitudinal& t, double kappa_signed, const Contact& c) {
  const double fz0 = t.lfzo * t.fnomin_n;
  const double dfz = (c.fz_n - fz0) / fz0;
  const double dpi = (c.pressure_pa - t.nompres_pa) / t.nompres_pa;
  const double lmu_star = t.lmux / (1.0 + c.lmuv * c.slip_speed_mps / t.longvl_mps);
  Mf61Terms m{};
  m.cx = t.pcx1;
  const double mux =
      (t.pdx1 + t.pdx2 * dfz) * (1 + t.ppx3 * dpi + t.ppx4 * dpi * dpi) * lmu_star;  // no camber
  m.dx = mux * c.fz_n;
  m.shx = t.phx1 + t.phx2 * dfz;
  const double kx = kappa_signed + m.shx;
  m.ex =
      std::min(1.0, (t.pex1 + t.pex2 * dfz + t.pex3 * dfz * dfz) * (1 - t.pex4 * (kx > 0   ? 1.0
                                                                                  : kx < 0 ? -1.0
                                                                                           : 0.0)));
  const double kxk = c.fz_n * (t.pkx1 + t.pkx2 * dfz) * std::exp(t.pkx3 * dfz) *
                     (1 + t.ppx1 * dpi + t.ppx2 * dpi * dpi) * t.lkx;
  m.bx = kxk / (m.cx * m.dx + 1e-9);
  m.svx = c.fz_n * (t.pvx1 + t.pvx2 * dfz) * t.lmux;
  return m;
}

}  // namespace

double mf61_braking_force_n(const Mf61Longitudinal& t, double kappa, const Contact& c) {
  // MF 6.1 convention: kappa < 0 when braking, Fx < 0; here braking slip and force are positive.
  const double ks = -kappa;
  const Mf61Terms m = terms(t, ks, c);
  const double x = ks + m.shx;
  const double bx = m.bx * x;
  const double fx = m.dx * std::sin(m.cx * std::atan(bx - m.ex * (bx - std::atan(bx)))) + m.svx;
  return -fx;
}

double mf61_slip_stiffness_n(const Mf61Longitudinal& t, const Contact& c) {
  const Mf61Terms m = terms(t, 0.0, c);
  return m.bx * m.cx * m.dx;
}

double brush_braking_force_n(const BrushTyre& b, double kappa, double fz_n, double v_mps) {
  // Theoretical slip sigma = kappa / (1 - kappa); theta = Cx / (3 mu Fz) (Pacejka, ch. 3).
  const double k = std::clamp(kappa, -0.99, 0.99);
  const double sigma = k / (1.0 - k);
  const double vs = std::abs(k) * v_mps;
  const double mu = b.mu_kinetic + (b.mu_static - b.mu_kinetic) * std::exp(-vs / b.v_c_mps);
  const double theta = b.cx_n / (3.0 * mu * fz_n);
  const double ts = theta * std::abs(sigma);
  const double mag = ts < 1.0 ? 3.0 * mu * fz_n * ts * (1.0 - ts + ts * ts / 3.0) : mu * fz_n;
  return sigma >= 0 ? mag : -mag;
}

}  // namespace brakefit::sim2
