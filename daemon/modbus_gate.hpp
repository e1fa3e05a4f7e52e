#pragma once
// The Modbus TCP request gate: what the server checks of a client's bytes before libmodbus sees
// them (libmodbus 3.1.6 trusts the MBAP length and the PDU's byte counts). Pure, so it is unit
// tested and fuzzed apart from sockets.
#include <cstddef>
#include <cstdint>

namespace brakefit::daemon {

inline constexpr std::size_t kMaxAdu = 260;  // MBAP 7 + PDU 253

enum class GateResult : std::uint8_t {
  NeedMore,   ///< not a whole request yet
  Drop,       ///< not Modbus TCP (protocol id, or a lying MBAP length): close the connection
  Exception,  ///< a whole request to answer with `exception` (01 or 03), not to pass on
  Pass,       ///< a whole, well-formed request of `total` bytes: modbus_reply may have it
};

struct GateDecision {
  GateResult result = GateResult::NeedMore;
  std::size_t total = 0;       ///< bytes of this request (Exception and Pass)
  std::uint8_t exception = 0;  ///< MODBUS_EXCEPTION_* for Exception
};

bool is_write_function(std::uint8_t fc);

/// buf holds n bytes received from a client, the next request at the front.
/// write_allowed: writes are enabled and this client is on the allow-list.
GateDecision gate_request(const std::uint8_t* buf, std::size_t n, bool write_allowed);

}  // namespace brakefit::daemon
