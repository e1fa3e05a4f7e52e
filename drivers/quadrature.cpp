#include "drivers/quadrature.hpp"

namespace brakefit::drivers {

void QuadratureDecoder::edge(bool line_b, bool level, std::int64_t t_ns) {
  ++edges_;
  const std::uint8_t bit = line_b ? 1 : 2;
  const auto next = static_cast<std::uint8_t>(level ? (state_ | bit) : (state_ & ~bit));
  const int step = kTable[static_cast<std::size_t>((state_ << 2) | next)];
  if (step == kIllegal || next == state_) {
    ++illegal_;  // both lines moved, or an edge back to the level we already had: edges were lost
  } else {
    count_ += step;
    last_edge_ns_ = t_ns;
  }
  state_ = next;
}

}  // namespace brakefit::drivers
