#pragma once
// MF 6.1 pure longitudinal force (Pacejka, Tire and Vehicle Dynamics, 3rd ed., 4.3.2; no camber,
// no turn slip), the coefficients a .tir file carries for it, and its evaluation as a template so
// that the joint fit (mf61_fit.hpp) gets exact derivatives from Ceres' automatic differentiation.
//
// Conventions: ISO (a braking wheel has kappa < 0 and Fx < 0) inside the formula and in the file;
// brakefit's curves carry braking slip and force as positive numbers, so braking_force_n() takes
// slip s = -kappa and returns -Fx.
#include <array>
#include <cmath>
#include <string_view>

namespace brakefit::tyre {

/// The coefficients the fit can free, in the order of the parameter vector.
enum class Coef : std::size_t {
  PCX1,
  PDX1,
  PDX2,
  PEX1,
  PEX2,
  PEX3,
  PEX4,
  PKX1,
  PKX2,
  PKX3,
  PHX1,
  PHX2,
  PVX1,
  PVX2,
  PPX1,
  PPX2,
  PPX3,
  PPX4,
  LMUV,
};
inline constexpr std::size_t kCoefCount = 19;
using CoefVector = std::array<double, kCoefCount>;

/// The .tir key ("PCX1", ..., "LMUV").
std::string_view coef_name(std::size_t i);
/// The plausible range the fit keeps each coefficient in (published car and van tyre values lie
/// well inside), and the value a coefficient the data cannot identify is held at.
struct CoefRange {
  double lo, hi, held_default;
};
const CoefRange& coef_range(std::size_t i);

/// The operating point's reference values (the file's FNOMIN, NOMPRES, LONGVL) and scalings.
struct Mf61Reference {
  double fnomin_n = 4000;
  double nompres_pa = 2.2e5;
  double longvl_mps = 16.7;
  double lfzo = 1, lcx = 1, lmux = 1, lex = 1, lkx = 1, lhx = 1, lvx = 1;
};

struct Mf61Tyre {
  Mf61Reference ref;
  CoefVector coef{};
};

/// Where a curve was measured: wheel load, inflation pressure and the wheel centre's speed.
struct OperatingPoint {
  double fz_n = 4000;
  double pressure_pa = 2.2e5;
  double speed_mps = 5.0 / 3.6;
};

/// Scalings applied on top of a tyre's own (roller vs road): LMUX, LKX, LCX, LEX.
template <typename T>
struct Scalings {
  T lmux = T(1), lkx = T(1), lcx = T(1), lex = T(1);
};

/// Fx (ISO) at longitudinal slip kappa. c holds the kCoefCount coefficients.
template <typename T>
T mf61_fx(const T* c, const Mf61Reference& r, const OperatingPoint& op, double kappa,
          const Scalings<T>& s = {}) {
  using std::atan;
  using std::exp;
  using std::sin;
  auto at = [c](Coef k) { return c[static_cast<std::size_t>(k)]; };
  const double fz0 = r.lfzo * r.fnomin_n;
  const double dfz = (op.fz_n - fz0) / fz0;
  const double dpi = (op.pressure_pa - r.nompres_pa) / r.nompres_pa;
  const double slip_speed_mps = std::abs(kappa) * op.speed_mps;
  const T lmux = T(r.lmux) * s.lmux;
  const T lmu_star = lmux / (T(1) + at(Coef::LMUV) * (slip_speed_mps / r.longvl_mps));
  const T shx = (at(Coef::PHX1) + at(Coef::PHX2) * dfz) * r.lhx;
  const T kx = T(kappa) + shx;
  const T cx = at(Coef::PCX1) * r.lcx * s.lcx;
  const T mux = (at(Coef::PDX1) + at(Coef::PDX2) * dfz) *
                (T(1) + at(Coef::PPX3) * dpi + at(Coef::PPX4) * (dpi * dpi)) * lmu_star;
  const T dx = mux * op.fz_n;
  const double sign_kx = kx < T(0) ? -1.0 : (kx > T(0) ? 1.0 : 0.0);
  T ex = (at(Coef::PEX1) + at(Coef::PEX2) * dfz + at(Coef::PEX3) * (dfz * dfz)) *
         (T(1) - at(Coef::PEX4) * sign_kx) * r.lex * s.lex;
  if (ex > T(1)) ex = T(1);
  const T kxk = op.fz_n * (at(Coef::PKX1) + at(Coef::PKX2) * dfz) * exp(at(Coef::PKX3) * dfz) *
                (T(1) + at(Coef::PPX1) * dpi + at(Coef::PPX2) * (dpi * dpi)) * r.lkx * s.lkx;
  const T bx = kxk / (cx * dx + 1e-6);
  const T svx = op.fz_n * (at(Coef::PVX1) + at(Coef::PVX2) * dfz) * r.lvx * lmux;
  const T bk = bx * kx;
  return dx * sin(cx * atan(bk - ex * (bk - atan(bk)))) + svx;
}

/// Braking force (positive) at braking slip s (0..1).
double braking_force_n(const Mf61Tyre& t, const OperatingPoint& op, double slip_ratio);

}  // namespace brakefit::tyre
