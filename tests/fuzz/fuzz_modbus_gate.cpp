// The Modbus TCP request gate: a client's bytes are cut into requests as the server cuts them;
// whatever the gate passes goes to libmodbus's modbus_reply on the daemon's register mapping (its
// reply written to a socketpair), so a request the gate lets through cannot make libmodbus read
// or write out of bounds.
#include <modbus.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>

#include "daemon/modbus_gate.hpp"
#include "daemon/registers.hpp"

namespace {

struct Server {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", 1502);
  modbus_mapping_t* map = modbus_mapping_new(0, 0, brakefit::daemon::kHoldingRegisters,
                                             brakefit::daemon::kInputRegisters);
  int fds[2] = {-1, -1};
  Server() {
    if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK, 0, fds) != 0) std::abort();
    modbus_set_socket(ctx, fds[0]);
  }
  void drain() const {
    char b[4096];
    while (::read(fds[1], b, sizeof b) > 0) {
    }
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace brakefit::daemon;
  static Server srv;
  if (size == 0) return 0;
  const bool allowed = data[0] & 1;  // the first byte: is this client allowed to write?
  const std::uint8_t* p = data + 1;
  std::size_t n = size - 1;
  while (n > 0) {
    const GateDecision g = gate_request(p, n, allowed);
    if (g.result == GateResult::NeedMore || g.result == GateResult::Drop) break;
    if (g.total < 8 || g.total > n || g.total > kMaxAdu) std::abort();  // the gate's promise
    std::array<std::uint8_t, kMaxAdu> adu{};
    std::copy_n(p, g.total, adu.begin());
    if (g.result == GateResult::Exception)
      modbus_reply_exception(srv.ctx, adu.data(), g.exception);
    else
      modbus_reply(srv.ctx, adu.data(), static_cast<int>(g.total), srv.map);
    srv.drain();
    p += g.total;
    n -= g.total;
  }
  return 0;
}
