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

unsigned u16_at(const std::uint8_t* adu, std::size_t i) {
  return (static_cast<unsigned>(adu[i]) << 8) | adu[i + 1];
}

/// False for the requests libmodbus 3.1.6 answers with an exception after sleeping its response
/// timeout (0.5 s) and flushing the socket: a quantity out of range, a byte count that does not
/// match it, a coil value other than 0x0000/0xFF00, an unknown function. Its server thread would
/// sleep for each one, stalling every other client: the gate answers these itself, at once.
bool quantities_ok(const std::uint8_t* adu) {
  const std::uint8_t fc = adu[7];
  switch (fc) {
    case 1:
    case 2: {
      const unsigned nb = u16_at(adu, 10);
      return nb >= 1 && nb <= 2000;
    }
    case 3:
    case 4: {
      const unsigned nb = u16_at(adu, 10);
      return nb >= 1 && nb <= 125;
    }
    case 5: {
      const unsigned v = u16_at(adu, 10);
      return v == 0xFF00 || v == 0x0000;
    }
    case 15: {
      const unsigned nb = u16_at(adu, 10);
      return nb >= 1 && nb <= 1968 && adu[12] == (nb + 7) / 8;
    }
    case 16: {
      const unsigned nb = u16_at(adu, 10);
      return nb >= 1 && nb <= 123 && adu[12] == nb * 2;
    }
    case 23: {
      const unsigned nb_read = u16_at(adu, 10), nb_write = u16_at(adu, 14);
      return nb_read >= 1 && nb_read <= 125 && nb_write >= 1 && nb_write <= 121 &&
             adu[16] == nb_write * 2;
    }
    case 6:
    case 17:  // report server id
    case 22:
      return true;
    default:
      return false;
  }
}

bool known_function(std::uint8_t fc) {
  return (fc >= 1 && fc <= 6) || fc == 15 || fc == 16 || fc == 17 || fc == 22 || fc == 23;
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
  // An unknown function, or a write from a client that may not write: 01; a malformed known
  // request: 03. Everything else passes to libmodbus.
  const bool known = known_function(buf[7]);
  const bool refused_write = is_write_function(buf[7]) && !write_allowed;
  const bool well_formed = known && pdu_length_ok(buf, d.total) && quantities_ok(buf);
  if (!known || (well_formed && refused_write)) {
    d.result = GateResult::Exception;
    d.exception = MODBUS_EXCEPTION_ILLEGAL_FUNCTION;
  } else if (!well_formed) {
    d.result = GateResult::Exception;
    d.exception = MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
  } else {
    d.result = GateResult::Pass;
  }
  return d;
}

}  // namespace brakefit::daemon
