#pragma once
// A bench's measurement model: the instrument effects `brakefit gap` named on a set of runs, with
// their magnitudes, held when each event of that bench is fitted so that the published B, C, D,
// E describe the tyre, not the instrument. The effects are undone on the event's points (the
// inverse of predict's force and slip sides): the points left are the tyre's steady-state curve,
// which every method (SOM, MLP, LM, hybrid) fits as it fits a raw curve.
#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include "core/curve.hpp"
#include "core/gap/gap.hpp"

namespace brakefit::gap {

struct BenchEffect {
  Effect effect{};
  double value = 0.0;    ///< in the effect's parameter unit (effect_param(effect).name)
  double stderr_ = 0.0;  ///< its standard error from the diagnosis's fit (0: not known)
  /// The effect's further parameters, in effect_params' order: load transfer's kx_load_ratio and
  /// pitch_lag_s and pitch_mode_s2 (empty: none, or their defaults, the published tyres' ratio,
  /// no lag and no pitch mode).
  std::vector<double> more;
  std::string origin;  ///< where the values come from, written as a comment (empty: the diagnosis)
};

struct BenchModel {
  std::string condition;  ///< "roller" or "ground": the bench the runs came from
  std::vector<BenchEffect> effects;
  /// Named effects of the tyre or the vehicle, not the instrument (load transfer, speed
  /// friction): the model does not undo them; they stay in the tyre's curve.
  std::vector<std::string> not_held;
  std::string model_hash, date;
  std::vector<std::string> runs;
};

/// The effects a bench model undoes: lags (relaxation, time offset), the wheel's inertia, the
/// brake's threshold and a slip offset; on the ground also the vehicle's load transfer (what is
/// published is the tyre at the wheel's static load).
bool is_bench_effect(Effect e, Condition c);
/// The bench model of a diagnosis: its named effects that it undoes, at the final fit's values and
/// standard errors.
BenchModel bench_model_from(const Report& rep, Condition c);

/// The vehicle's load transfer onto a wheel, declared from its geometry: the wheel's load grows
/// (front axle) or falls (rear) by m h / (2 L) per m/s^2 of deceleration, shared by the axle's two
/// wheels; held as the diagnosis's law (D by 1 + q a, q = dFz/Fz per m/s^2 through the tyre's
/// d ln D / d ln Fz; the slip stiffness by its load ratio; no pitch lag). laws: the tyre's own
/// (laws_source names its file) or, by default, published tyres'.
BenchEffect declared_load_transfer(double vehicle_mass_kg, double cg_height_m, double wheelbase_m,
                                   double wheel_load_n, bool front_axle,
                                   const tyre::LoadLaws& laws = {},
                                   const std::string& laws_source = {});
/// TOML text: a header comment (model hash, runs, date), schema/version, condition, and one
/// [effects.NAME] table per effect with its parameter and PARAM_stderr.
std::string format_bench_model(const BenchModel& m);
/// Throws InputError "SOURCE: key 'effects.x.y': ..." on unknown effects or keys, bad values.
BenchModel parse_bench_model(std::string_view text, const std::string& source);

/// A run's points with the bench's effects undone (a load transfer: each point moved to the
/// wheel's static load, force over 1 + q a, slip times (1 + q a)^(ratio - 1)). Points that cannot
/// be the tyre's are left out, each kind counted with its reason (the force channel's lead past the
/// run's end). The run itself ends at the lock-up runaway or a locked wheel (condition): past there
/// the force is the brake holding the rim, not the tyre's.
struct TyrePoints {
  Curve curve;
  /// Reason and points (0: a stretch the conditioning already cut, such as the runaway).
  std::vector<std::pair<std::string, std::size_t>> left_out;
};
TyrePoints tyre_points(const Run& r, const BenchModel& m);

}  // namespace brakefit::gap
