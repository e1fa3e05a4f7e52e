#pragma once
// A late force channel read at its delay (realign.cpp): the runs conditioned again with the
// channel read the fitted time offset later, and diagnosed again.
#include <cstddef>
#include <optional>
#include <vector>

#include "core/gap/gap.hpp"

namespace brakefit::gap {

/// A delay under this is not realigned: it moves where a run is cut by under 20 ms of its curve
/// (10 samples at 500 Hz), less than the smoother's window spans.
constexpr double kRealignMinDelayS = 0.02;

/// Reads each channel advance_s later than the times t_s: channels[k][i] becomes that channel's
/// sample nearest t_s[i] + advance_s, and every array (the channels and `others`) ends at the
/// last sample whose advanced time lies within the record.
void advance_channel(std::vector<double>& t_s, double advance_s,
                     const std::vector<std::vector<double>*>& channels,
                     const std::vector<std::vector<double>*>& others);

/// Where rep names a time offset of at least kRealignMinDelayS on ground runs that each have
/// their source: the runs conditioned again with the force channel read that much later, diagnosed again, and the
/// two reports joined (the offset, the realigned runs' names, estimates and gap left); nothing
/// where the realigned runs cannot be diagnosed.
std::optional<Report> realigned(const Report& rep, const std::vector<Run>& runs,
                                const MfParams& start, const Options& o);

}  // namespace brakefit::gap
