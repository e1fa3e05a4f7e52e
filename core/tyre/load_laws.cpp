#include "core/tyre/load_laws.hpp"

#include <fmt/format.h>

#include "core/curve.hpp"
#include "core/tyre/mf61.hpp"

namespace brakefit::tyre {

LoadLaws load_laws_at(const Mf61Tyre& t, double fz_n) {
  auto at = [&t](Coef k) { return t.coef[static_cast<std::size_t>(k)]; };
  const double fz0 = t.ref.lfzo * t.ref.fnomin_n;
  if (!(fz0 > 0) || !(fz_n > 0))
    throw InputError(fmt::format(
        "tyre load laws: the wheel load ({} N) and FNOMIN x LFZO ({} N) must be positive", fz_n,
        fz0));
  const double dfz = (fz_n - fz0) / fz0, x = fz_n / fz0;  // d dfz / d ln Fz = x
  const double mu = at(Coef::PDX1) + at(Coef::PDX2) * dfz;
  const double kx = at(Coef::PKX1) + at(Coef::PKX2) * dfz;
  if (!(mu > 0))
    throw InputError(fmt::format(
        "tyre load laws: PDX1 + PDX2 dfz is {:.4g} at {:.0f} N (not a peak friction)", mu, fz_n));
  if (!(kx > 0))
    throw InputError(fmt::format(
        "tyre load laws: PKX1 + PKX2 dfz is {:.4g} at {:.0f} N (not a slip stiffness)", kx, fz_n));
  LoadLaws l;
  l.peak_exponent = 1.0 + at(Coef::PDX2) * x / mu;
  const double kx_exponent = 1.0 + at(Coef::PKX2) * x / kx + at(Coef::PKX3) * x;
  l.kx_over_peak = kx_exponent / l.peak_exponent;
  const double braking = 1.0 + at(Coef::PEX4);  // MF 6.1's (1 - PEX4 sgn kappa), kappa < 0
  const double e =
      (at(Coef::PEX1) + at(Coef::PEX2) * dfz + at(Coef::PEX3) * dfz * dfz) * braking * t.ref.lex;
  const double de_per_ln_fz =
      (at(Coef::PEX2) + 2.0 * at(Coef::PEX3) * dfz) * x * braking * t.ref.lex;
  l.e_per_peak_scale = e >= 1.0 ? 0.0 : de_per_ln_fz / l.peak_exponent;
  return l;
}

}  // namespace brakefit::tyre
