#pragma once
// The second simulator's tyres: MF 6.1 pure longitudinal slip evaluated from a .tir file's
// coefficients (load, inflation pressure and slip-speed laws), and a brush-model family (not a
// Magic Formula: parabolic contact pressure, static/kinetic friction with a slip-speed decay).
// Written apart from sim/tyre.*: no code is shared.
#include <string>

#include "sim/second/tir.hpp"

namespace brakefit::sim2 {

struct Mf61Longitudinal {
  std::string name;
  double fnomin_n = 4000, nompres_pa = 2.2e5, longvl_mps = 16.7, iyy_kgm2 = 1.0;
  double lfzo = 1, lmux = 1, lkx = 1;
  double pcx1 = 1.6, pdx1 = 1, pdx2 = 0, pex1 = 0, pex2 = 0, pex3 = 0, pex4 = 0;
  double pkx1 = 20, pkx2 = 0, pkx3 = 0, phx1 = 0, phx2 = 0, pvx1 = 0, pvx2 = 0;
  double ppx1 = 0, ppx2 = 0, ppx3 = 0, ppx4 = 0;
};
/// The longitudinal part of a .tir file (missing coefficients are 0, scalings 1).
Mf61Longitudinal mf61_from_tir(const TirFile& f, const std::string& name);

/// Operating point of the contact patch.
struct Contact {
  double fz_n = 4000;
  double pressure_pa = 2.2e5;
  double slip_speed_mps = 0;  ///< |kappa| V
  double lmuv = 0;            ///< MF 6.1 slip-speed friction decay (0: off)
};

/// Braking force (positive) at braking slip kappa (1 - omega R / V, 0...1).
double mf61_braking_force_n(const Mf61Longitudinal& t, double kappa, const Contact& c);
/// The slip stiffness dF/dkappa at zero slip (MF 6.1 Kxk).
double mf61_slip_stiffness_n(const Mf61Longitudinal& t, const Contact& c);

/// Brush model: carcass-free bristles, parabolic pressure; friction mu(Vs) = mu_k + (mu_s - mu_k)
/// exp(-Vs / v_c). Same slip stiffness and peak scale as the MF tyre it is drawn around.
struct BrushTyre {
  double cx_n = 80000;  ///< slip stiffness per unit slip
  double mu_static = 1.0, mu_kinetic = 0.8, v_c_mps = 0.6;
};
double brush_braking_force_n(const BrushTyre& b, double kappa, double fz_n, double v_mps);

}  // namespace brakefit::sim2
