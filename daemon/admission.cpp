#include "daemon/admission.hpp"

#include <algorithm>
#include <map>

namespace brakefit::daemon {

Admission admit_connection(const std::vector<ConnectionView>& open, const std::string& ip,
                           int max_clients, int max_per_address,
                           const std::vector<std::string>& protected_ips) {
  auto is_protected = [&](const std::string& a) {
    return std::find(protected_ips.begin(), protected_ips.end(), a) != protected_ips.end();
  };
  std::map<std::string, int> per_address;
  for (const auto& c : open) ++per_address[c.ip];
  Admission a;
  if (per_address[ip] >= max_per_address) {
    a.reason = "per-address limit";
    return a;
  }
  a.admit = true;
  if (static_cast<int>(open.size()) < max_clients) return a;
  // Full: evict the idlest connection of the address that holds the most (never the newcomer's
  // own, which holds fewer than the limit and is not preferred over a heavier holder).
  int most = 0;
  for (const auto& [addr, n] : per_address)
    if (addr != ip && !is_protected(addr)) most = std::max(most, n);
  if (most == 0) {  // only the newcomer's own or protected connections are open
    a.admit = false;
    a.reason = "max_clients (the open connections are the newcomer's own or protected)";
    return a;
  }
  for (std::size_t i = 0; i < open.size(); ++i) {
    if (open[i].ip == ip || is_protected(open[i].ip) || per_address[open[i].ip] != most) continue;
    if (!a.evict || open[i].last_byte < open[*a.evict].last_byte) a.evict = i;
  }
  a.reason = "max_clients: the idlest connection of the busiest address makes room";
  return a;
}

}  // namespace brakefit::daemon
