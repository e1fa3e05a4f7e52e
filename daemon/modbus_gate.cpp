#include "daemon/modbus_gate.hpp"

#include <modbus.h>

namespace brakefit::daemon {

namespace {

/// True when the PDU length matches what the function code needs.
bool pdu_length_ok(const std::uint8_t* adu, std::size_t total) {
  const std::uint8_t fc = adu[7];
  const std::size_t len = total - 6;  // unit id + PDU
  switch (fc) {
    case 1:
    case 2:
    case 3:
    case 4:
    case 5:
    case 6:
      return len == 6;
    case 15:
    case 16:
      return len >= 7 && adu[12] == len - 7;
    case 22:
      return len == 8;
    case 23:
      return len >= 11 && adu[16] == len - 11;
    default:
      return len >= 2;
  }
}

}  // namespace

bool is_write_function(std::uint8_t fc) {
  return fc == 5 || fc == 6 || fc == 15 || fc == 16 || fc == 22 || fc == 23;
}

GateDecision gate_request(const std::uint8_t* buf, std::size_t n, bool write_allowed) {
  GateDecision d;
  if (n < 8) return d;
  const unsigned pid = (buf[2] << 8) | buf[3];
  const unsigned len = (buf[4] << 8) | buf[5];
  if (pid != 0 || len < 2 || len > kMaxAdu - 6) {
    d.result = GateResult::Drop;
    return d;
  }
  d.total = 6 + len;
  if (n < d.total) return d;
  if (!pdu_length_ok(buf, d.total)) {
    d.result = GateResult::Exception;
    d.exception = MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
  } else if (is_write_function(buf[7]) && !write_allowed) {
    d.result = GateResult::Exception;
    d.exception = MODBUS_EXCEPTION_ILLEGAL_FUNCTION;
  } else {
    d.result = GateResult::Pass;
  }
  return d;
}

}  // namespace brakefit::daemon
