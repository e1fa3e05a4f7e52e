#include "core/tyre/mf61.hpp"

namespace brakefit::tyre {

namespace {

constexpr std::array<std::string_view, kCoefCount> kNames = {
    "PCX1", "PDX1", "PDX2", "PEX1", "PEX2", "PEX3", "PEX4", "PKX1", "PKX2", "PKX3",
    "PHX1", "PHX2", "PVX1", "PVX2", "PPX1", "PPX2", "PPX3", "PPX4", "LMUV"};

// Ranges wide enough for every published car, van and truck tyre file we know of; the held
// defaults are MF 6.1's own (0 for every dependence, so a held law is "no dependence"), except
// PCX1 and PEX1, which have no neutral value: 1.65 and 0 are the typical values TNO's MF-Tyre
// documentation gives for a passenger car tyre.
constexpr std::array<CoefRange, kCoefCount> kRanges = {{
    {1.0, 2.5, 1.65},    // PCX1
    {0.2, 2.5, 1.0},     // PDX1
    {-0.6, 0.6, 0.0},    // PDX2
    {-4.0, 1.0, 0.0},    // PEX1
    {-4.0, 4.0, 0.0},    // PEX2
    {-4.0, 4.0, 0.0},    // PEX3
    {-1.0, 1.0, 0.0},    // PEX4
    {3.0, 80.0, 20.0},   // PKX1
    {-40.0, 40.0, 0.0},  // PKX2
    {-2.0, 2.0, 0.0},    // PKX3
    {-0.02, 0.02, 0.0},  // PHX1
    {-0.02, 0.02, 0.0},  // PHX2
    {-0.15, 0.15, 0.0},  // PVX1
    {-0.15, 0.15, 0.0},  // PVX2
    {-2.0, 2.0, 0.0},    // PPX1
    {-2.0, 2.0, 0.0},    // PPX2
    {-1.0, 1.0, 0.0},    // PPX3
    {-1.0, 1.0, 0.0},    // PPX4
    {0.0, 20.0, 0.0},    // LMUV
}};

}  // namespace

std::string_view coef_name(std::size_t i) {
  return kNames.at(i);
}
const CoefRange& coef_range(std::size_t i) {
  return kRanges.at(i);
}

double braking_force_n(const Mf61Tyre& t, const OperatingPoint& op, double slip_ratio) {
  return -mf61_fx<double>(t.coef.data(), t.ref, op, -slip_ratio);
}

}  // namespace brakefit::tyre
