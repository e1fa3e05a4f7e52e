#pragma once
// x4 quadrature decoding of one encoder's A/B lines from both-edge events. The 16-entry table maps
// (previous AB, new AB) to -1, 0 or +1; a transition that changes both lines, or an edge event that
// does not change its line's level, is illegal: the only sign that the kernel FIFO dropped events.
#include <array>
#include <cstdint>

namespace brakefit::drivers {

class QuadratureDecoder {
 public:
  /// Seeds the A/B levels (read with get_value() before the first event).
  void seed(bool a, bool b) { state_ = static_cast<std::uint8_t>((a ? 2 : 0) | (b ? 1 : 0)); }
  /// One edge on line A (line_b = false) or B to `level` at t_ns.
  void edge(bool line_b, bool level, std::int64_t t_ns);
  std::int64_t count_x4() const { return count_; }
  std::uint64_t illegal_transitions() const { return illegal_; }
  std::uint64_t edges() const { return edges_; }
  /// Time of the last counted edge (0 before the first).
  std::int64_t last_edge_ns() const { return last_edge_ns_; }

  /// kTable[(old << 2) | new]: +1 forward, -1 backward, 0 none, kIllegal both lines changed.
  static constexpr int kIllegal = 2;
  static constexpr std::array<int, 16> kTable = {
      0,        -1,       +1,       kIllegal,  // from 00
      +1,       0,        kIllegal, -1,        // from 01
      -1,       kIllegal, 0,        +1,        // from 10
      kIllegal, +1,       -1,       0,         // from 11
  };

 private:
  std::uint8_t state_ = 0;
  std::int64_t count_ = 0;
  std::uint64_t illegal_ = 0, edges_ = 0;
  std::int64_t last_edge_ns_ = 0;
};

}  // namespace brakefit::drivers
