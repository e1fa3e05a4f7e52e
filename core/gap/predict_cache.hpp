// What predict() derives from a run and one or two parameters alone, kept across one fit's
// evaluations.
#pragma once

#include <cstddef>
#include <functional>
#include <unordered_map>
#include <vector>

#include "core/gap/run.hpp"

namespace brakefit::gap {

/// The fits' Jacobians are central differences: each evaluation perturbs one parameter, so a
/// quantity that depends on the run and on one or two parameters (the body's pitch at the load's
/// lag and mode, the tyre's relaxation steps at its length, the declared filter's step decays)
/// is asked again at the same values for every other parameter. It is kept here, per run and
/// per the values it was computed at, for the last kPerKind values asked of each kind. A kept value
/// is the same computation's result, bit for bit: the fits take the same steps with it as without
/// it.
///
/// A cache belongs to one fit: it keys on the runs' addresses, which must stay put and unchanged
/// while it is used (the fits hold their runs const).
class PredictCache {
 public:
  enum class Kind { Pitch, Relax, FilterDecay };
  /// Entries kept per run and kind: the fit's point and the perturbations of the two parameters
  /// a kind can depend on (a pitch's lag and mode), and one spare.
  static constexpr std::size_t kPerKind = 6;

  /// The values of `kind` for run r at (a, b), computed by `make` on a miss.
  const std::vector<double>& get(const Run& r, Kind kind, double a, double b,
                                 const std::function<std::vector<double>()>& make);

 private:
  struct Entry {
    Kind kind;
    double a, b;
    std::vector<double> values;
    std::size_t used;
  };
  static constexpr std::size_t kKinds = 3;
  std::unordered_map<const Run*, std::vector<Entry>> runs_;
  std::size_t clock_ = 0;
};

}  // namespace brakefit::gap
