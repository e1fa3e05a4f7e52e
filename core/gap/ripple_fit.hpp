#pragma once
// The regressions an encoder ripple is estimated by: the model's force answer to a slip ripple at
// an encoder's angle (a pair of columns, cos and sin), a least-squares fit of a run's residual on
// a trend and those columns, and a scan of the phase alone at a known amplitude.
#include <array>
#include <cstddef>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

struct RippleFit : SpeedRipple {
  std::array<double, 2> se{};  ///< standard error of the amplitude
  double ssr = 0;              ///< residual sum of squares of the regression
};

/// The fitted model a ripple is seen through (the baseline, or the model with the named effects).
struct RippleModel {
  const std::vector<double>& params;
  const std::vector<Effect>& effects;
};

using ColumnPair = std::pair<std::vector<double>, std::vector<double>>;

/// An encoder's ripple columns (e: 0 the wheel, 1 the reference) at frequency_scale times its
/// revolution rate (ripple_fit.cpp says how they pass the model).
ColumnPair ripple_columns(const Run& r, const RippleModel& m, std::size_t e,
                          double frequency_scale);

/// One run's ripple columns through the model, each encoder and rate computed once: the
/// significance, narrow-band and short-run fits ask for the same columns again (two predicts a
/// column; the run's slip is not changed until the estimate is taken out).
class RunColumns {
 public:
  RunColumns(const Run& r, const RippleModel& m) : r_(r), m_(m) {}
  const Run& run() const { return r_; }
  const ColumnPair& at(std::size_t e, double frequency_scale);

 private:
  const Run& r_;
  const RippleModel& m_;
  std::map<std::pair<std::size_t, double>, ColumnPair> cache_;
};

/// Regresses the residual y on a polynomial trend in time (order trend, kept out of the ripple)
/// and the model's answer to a slip ripple at the encoders' angles (ripple_columns).
RippleFit fit_ripple(RunColumns& columns, const std::vector<double>& y, std::array<bool, 2> use,
                     int trend, std::array<double, 2> frequency_scale = {1.0, 1.0});

/// A run too short to tell a ripple's amplitude from its trend: with the amplitude known from the
/// encoder's longer runs, only the phase is scanned (a linear trend refitted at each), and kept
/// when it explains some of the residual. Returns the cos and sin coefficients, or nothing.
std::optional<std::array<double, 2>> scan_phase(RunColumns& columns, const std::vector<double>& y,
                                                std::size_t e, double amplitude);

}  // namespace brakefit::gap
