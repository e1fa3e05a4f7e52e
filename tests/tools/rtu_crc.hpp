#pragma once
// The Modbus RTU CRC-16 (polynomial 0xA001 reflected, initial 0xFFFF; sent low byte first), for
// the fake RTU slaves of the tests and the virtual bench (the daemon itself uses libmodbus).
#include <cstddef>
#include <cstdint>

namespace brakefit::test {

inline std::uint16_t rtu_crc16(const std::uint8_t* p, std::size_t n) {
  std::uint16_t crc = 0xFFFF;
  for (std::size_t i = 0; i < n; ++i) {
    crc ^= p[i];
    for (int b = 0; b < 8; ++b)
      crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001)
                      : static_cast<std::uint16_t>(crc >> 1);
  }
  return crc;
}

}  // namespace brakefit::test
