#include "sim/tyre.hpp"

#include <algorithm>
#include <cmath>

namespace brakefit::sim {

namespace {

struct Coeffs {
  double B, C, D, E, SH, SV;
};

Coeffs coeffs(const TyreMf61& t, const TyreState& s, double sgn_kappa_x) {
  const double fz0 = t.FNOMIN;
  const double dfz = (s.fz_n - fz0) / fz0;
  const double dpi = (s.pressure_bar - t.NOMPRES_bar) / t.NOMPRES_bar;
  const double lambda_star = s.lambda_mu / (1.0 + s.lambda_mu_v * s.slip_speed_mps / t.LONGVL);
  const double mu = (t.PDX1 + t.PDX2 * dfz) * (1 + t.PPX3 * dpi + t.PPX4 * dpi * dpi) * lambda_star;
  Coeffs c;
  c.C = t.PCX1;
  c.D = mu * s.fz_n;
  c.E = std::min(1.0, (t.PEX1 + t.PEX2 * dfz + t.PEX3 * dfz * dfz) * (1 - t.PEX4 * sgn_kappa_x));
  const double kx = s.fz_n * (t.PKX1 + t.PKX2 * dfz) * std::exp(t.PKX3 * dfz) *
                    (1 + t.PPX1 * dpi + t.PPX2 * dpi * dpi);
  c.B = kx / (c.C * c.D);
  c.SH = s.shifts ? t.PHX1 + t.PHX2 * dfz : 0.0;
  c.SV = s.shifts ? s.fz_n * (t.PVX1 + t.PVX2 * dfz) : 0.0;
  return c;
}

}  // namespace

double fx_mf61(const TyreMf61& t, const TyreState& s, double kappa) {
  if (t.family == TyreMf61::Family::Burckhardt) {
    const double a = std::abs(kappa);
    const double mu =
        t.BURCKHARDT_C1 * (1.0 - std::exp(-t.BURCKHARDT_C2 * a)) - t.BURCKHARDT_C3 * a;
    return (kappa < 0 ? -1.0 : 1.0) * s.fz_n * s.lambda_mu * mu;
  }
  const TyreState s0 = s;
  const double sh = s.shifts ? t.PHX1 + t.PHX2 * (s.fz_n - t.FNOMIN) / t.FNOMIN : 0.0;
  const double kx = kappa + sh;
  const Coeffs c = coeffs(t, s0, kx < 0 ? -1.0 : (kx > 0 ? 1.0 : 0.0));
  const double bk = c.B * kx;
  return c.D * std::sin(c.C * std::atan(bk - c.E * (bk - std::atan(bk)))) + c.SV;
}

MfParams pac96_equivalent(const TyreMf61& t, const TyreState& s) {
  const Coeffs c = coeffs(t, s, -1.0);  // braking: kappa_x < 0
  // F(s) = -Fx(-s) = D sin(C atan(B(s - SH) ...)) - SV.
  return MfParams{c.B, c.C, c.D, c.E, -c.SH, -c.SV};
}

double slip_stiffness(const TyreMf61& t, const TyreState& s) {
  const Coeffs c = coeffs(t, s, -1.0);
  return c.B * c.C * c.D;
}

}  // namespace brakefit::sim
