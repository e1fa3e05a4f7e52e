#pragma once
// What the referee's draws (referee_draws.cpp), its trials (referee.cpp) and their scoring
// (referee_score.cpp) share.
#include <string>

#include "core/tyre/load_laws.hpp"
#include "sim/referee.hpp"
#include "sim/scenario.hpp"

namespace brakefit::sim::detail {

/// d ln D / d ln Fz of the simulated tyre at the scenario's load: the load transfer's effect on
/// D (the diagnosis parameter) per unit of relative load change.
double d_ln_d_per_ln_fz(const Scenario& s);
/// The simulated tyre's load laws at the scenario's load, read off its Pacejka-96 equivalents at
/// loads 1 % apart: d ln D / d ln Fz, d ln (B C D) over it, and dE over the peak's change.
tyre::LoadLaws load_laws(const Scenario& s);

/// A relaxation (sigma / V) or a time offset: at one speed, one lag.
bool is_lag(const std::string& e);

/// A trial's result: the diagnosis's report scored against the injection (referee_score.cpp).
TrialResult score(const Injection& inj, const gap::Report& rep);

}  // namespace brakefit::sim::detail
