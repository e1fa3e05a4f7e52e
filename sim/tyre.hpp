#pragma once
// MF 6.1 pure longitudinal slip (shared/docs/physics.md §2) with the example TNO 205/60R15 tyre.
// MF 6.1 uses kappa < 0 when braking; callers pass the signed kappa.
#include "core/magic_formula.hpp"

namespace brakefit::sim {

struct TyreMf61 {
  /// Burckhardt: mu(s) = c1 (1 - exp(-c2 s)) - c3 s (dry asphalt), a friction curve that is not a
  /// Magic Formula: the gap diagnosis must not invent an effect for it (misspecified tyre).
  enum class Family { MagicFormula, Burckhardt } family = Family::MagicFormula;
  double BURCKHARDT_C1 = 1.2801, BURCKHARDT_C2 = 23.99, BURCKHARDT_C3 = 0.52;
  double FNOMIN = 4000.0;    ///< N
  double NOMPRES_bar = 2.2;  ///< 220 kPa
  double LONGVL = 16.7;      ///< m/s
  double PCX1 = 1.579;
  double PDX1 = 1.0422, PDX2 = -0.0827, PDX3 = 0.0;
  double PEX1 = 0.11185, PEX2 = 0.3127, PEX3 = 0.0, PEX4 = 0.001603;
  double PKX1 = 21.69, PKX2 = 13.774, PKX3 = -0.4119;
  double PHX1 = 2.1585e-4, PHX2 = 0.0011538;
  double PVX1 = 1.5973e-5, PVX2 = 1.043e-4;
  double PPX1 = -0.3489, PPX2 = 0.382, PPX3 = -0.09634, PPX4 = 0.06447;
};

struct TyreState {
  double fz_n = 4000.0;
  double pressure_bar = 2.2;
  double slip_speed_mps = 0.0;  ///< |kappa| * V, for slip-speed friction
  double lambda_mu = 1.0;       ///< friction scaling (e.g. roller surface)
  double lambda_mu_v = 0.0;     ///< slip-speed friction decay (0 = off)
  bool shifts = false;          ///< SHx, SVx (slip / force offsets)
};

/// Longitudinal force Fx [N] at signed kappa (braking: kappa < 0, Fx < 0).
double fx_mf61(const TyreMf61& t, const TyreState& s, double kappa);
/// The equivalent Pac96 parameters in brakefit's convention (positive braking slip and force):
/// F(s) = -Fx(-s). Shifts are included when s.shifts (sign-converted), else zero.
MfParams pac96_equivalent(const TyreMf61& t, const TyreState& s);
/// Longitudinal slip stiffness Kx [N per unit slip].
double slip_stiffness(const TyreMf61& t, const TyreState& s);

}  // namespace brakefit::sim
