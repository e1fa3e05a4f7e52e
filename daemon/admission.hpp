#pragma once
// Who gets a Modbus TCP connection slot. One address may hold at most max_per_address
// connections; when all max_clients slots are taken, a new address still gets one: the idlest
// connection of the address holding the most is evicted for it. So one host (a misbehaving SCADA
// poller, a scan) can never lock the other stations out. A protected address (the station
// software's own) is never evicted: a flood of new addresses takes the others' slots, or is
// refused. Pure: the server applies the decision.
#include <chrono>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace brakefit::daemon {

struct ConnectionView {
  std::string ip;
  std::chrono::steady_clock::time_point last_byte;
};

struct Admission {
  bool admit = false;
  std::optional<std::size_t> evict;  ///< index of the connection to close first
  const char* reason = "";           ///< why rejected or evicted
};

Admission admit_connection(const std::vector<ConnectionView>& open, const std::string& ip,
                           int max_clients, int max_per_address,
                           const std::vector<std::string>& protected_ips = {});

}  // namespace brakefit::daemon
