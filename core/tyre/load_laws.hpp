#pragma once
// How an MF 6.1 tyre's longitudinal curve follows its wheel load: the peak's, the slip stiffness's
// and the curvature's load laws, linearised at one load. A load transfer moves the load while a
// run brakes; the gap diagnosis fits how much the peak moves (its scale per m/s^2 of
// deceleration) and reads the load's own change through these laws.
namespace brakefit::tyre {

struct Mf61Tyre;  // core/tyre/mf61.hpp

/// The load laws at one wheel load. The defaults are car and van tyres' at their nominal loads
/// (the four .tir files sim/second reads, TNO's published 205/60R15 and three composed in
/// published ranges: d ln D / d ln Fz 0.87-0.97, d ln Kx / d ln D 1.15-1.33, E's change per
/// unit of D's 0.13-0.34), which the diagnosis holds where the tyre's own file is not given.
struct LoadLaws {
  /// d ln D / d ln Fz: MF 6.1's D = (PDX1 + PDX2 dfz) Fz gives 1 + PDX2 (Fz/Fz0) / (PDX1 + PDX2
  /// dfz).
  double peak_exponent = 0.93;
  /// d ln Kx / d ln D, Kx = B C D = Fz (PKX1 + PKX2 dfz) exp(PKX3 dfz).
  double kx_over_peak = 1.25;
  /// dE per relative change of D (dE / d ln Fz over peak_exponent), E = (PEX1 + PEX2 dfz + PEX3
  /// dfz^2)(1 + PEX4) braking; 0 where E is at its bound 1. Held at 0.25: each of the four
  /// files has E grow with the load, and a held E that does not leaves the peak's change to carry
  /// the curve's whole reshaping.
  double e_per_peak_scale = 0.25;
};

/// The spread of those four tyres' laws. Where the tyre's own file is not given, a load
/// transfer's magnitude is also read at each end of it: how far the laws alone move it (a tyre
/// whose laws lie outside the spread reads outside that band). Published files of other tyres
/// spread wider: at their nominal loads d ln Kx / d ln D is 1.43 for MSC's 235/60R16 car tyre,
/// 0.93 for a 335/65R22.5 truck tyre and 0.73 for a 37x12.5R16.5 off-road tyre.
struct PublishedLoadLawRange {
  double peak_exponent_low = 0.87, peak_exponent_high = 0.97;
  double kx_over_peak_low = 1.15, kx_over_peak_high = 1.33;
};
inline constexpr PublishedLoadLawRange kPublishedLoadLawRange{};
static_assert(kPublishedLoadLawRange.peak_exponent_low <= LoadLaws{}.peak_exponent &&
                  LoadLaws{}.peak_exponent <= kPublishedLoadLawRange.peak_exponent_high &&
                  kPublishedLoadLawRange.kx_over_peak_low <= LoadLaws{}.kx_over_peak &&
                  LoadLaws{}.kx_over_peak <= kPublishedLoadLawRange.kx_over_peak_high,
              "the published laws held lie inside their spread");

/// The tyre's load laws at wheel load fz_n (braking, the file's scalings LFZO and LEX applied).
/// Throws InputError naming the coefficient where a law has no slope there (PDX1 + PDX2 dfz or
/// PKX1 + PKX2 dfz not positive: the file describes no tyre at that load).
LoadLaws load_laws_at(const Mf61Tyre& t, double fz_n);

}  // namespace brakefit::tyre
