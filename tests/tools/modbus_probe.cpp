// modbus_probe: a libmodbus client for brakefitd's register map (tests and benchmarks).
//   modbus_probe [--host H] --port P read          every register by name, decoded, as JSON
//   modbus_probe [--host H] --port P load --clients N --seconds S
//                                                   requests/s of N clients reading the event block
#include <modbus.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "brakefit/version.hpp"
#include "daemon/registers.hpp"

using namespace brakefit::daemon;

namespace {

modbus_t* connect(const std::string& host, int port) {
  modbus_t* m = modbus_new_tcp(host.c_str(), port);
  modbus_set_response_timeout(m, 2, 0);
  if (!m || modbus_connect(m) != 0) {
    std::cerr << "modbus_probe: cannot connect to " << host << ":" << port << ": "
              << modbus_strerror(errno) << "\n";
    std::exit(2);
  }
  return m;
}

int read_all(const std::string& host, int port) {
  modbus_t* m = connect(host, port);
  std::vector<std::uint16_t> in(kInputRegisters), hold(kHoldingRegisters);
  for (int base = 0; base < kInputRegisters; base += 100) {
    const int n = std::min(100, kInputRegisters - base);
    if (modbus_read_input_registers(m, base, n, in.data() + base) != n) {
      std::cerr << "modbus_probe: read input registers " << base << ": " << modbus_strerror(errno)
                << "\n";
      return 1;
    }
  }
  if (modbus_read_registers(m, 0, kHoldingRegisters, hold.data()) != kHoldingRegisters) {
    std::cerr << "modbus_probe: read holding registers: " << modbus_strerror(errno) << "\n";
    return 1;
  }
  nlohmann::ordered_json regs;
  for (const auto& r : register_map()) {
    const auto* t = r.table == RegTable::Input ? in.data() : hold.data();
    switch (r.type) {
      case RegType::U16:
        regs[r.name] = t[r.address];
        break;
      case RegType::U32:
        regs[r.name] = (static_cast<std::uint32_t>(t[r.address]) << 16) | t[r.address + 1];
        break;
      case RegType::F32: {
        const float f = unpack_f32_abcd(t[r.address], t[r.address + 1]);
        regs[r.name] =
            std::isfinite(f) ? nlohmann::ordered_json(f) : nlohmann::ordered_json(nullptr);
        break;
      }
      case RegType::Ascii: {
        std::string s;
        for (int i = 0; i < r.count; ++i)
          for (int sh : {8, 0}) {
            const char c = static_cast<char>((t[r.address + i] >> sh) & 0xFF);
            if (c) s += c;
          }
        regs[r.name] = s;
        break;
      }
    }
  }
  nlohmann::ordered_json j;
  j["schema"] = "brakefit.modbus_probe/1";
  j["version"] = brakefit::kVersion;
  j["consistent"] = regs["event.seq_begin"] == regs["event.seq"];
  j["registers"] = regs;
  std::cout << j.dump() << "\n";
  modbus_close(m);
  modbus_free(m);
  return 0;
}

int load(const std::string& host, int port, int clients, double seconds) {
  std::atomic<std::uint64_t> ok{0}, failed{0};
  std::atomic<bool> stop{false};
  std::vector<std::thread> th;
  const int base = reg("event.seq_begin").address;
  const int n = reg("event.seq").address - base + 1;
  for (int c = 0; c < clients; ++c)
    th.emplace_back([&] {
      modbus_t* m = connect(host, port);
      std::uint16_t regs[125];
      while (!stop) {
        if (modbus_read_input_registers(m, base, n, regs) == n)
          ++ok;
        else
          ++failed;
      }
      modbus_close(m);
      modbus_free(m);
    });
  const auto t0 = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  stop = true;
  for (auto& t : th) t.join();
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::ordered_json j;
  j["schema"] = "brakefit.modbus_load/1";
  j["version"] = brakefit::kVersion;
  j["clients"] = clients;
  j["registers_per_request"] = n;
  j["seconds"] = s;
  j["requests"] = ok.load();
  j["failed"] = failed.load();
  j["requests_per_s"] = static_cast<double>(ok.load()) / s;
  std::cout << j.dump() << "\n";
  return failed.load() == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  std::string host = "127.0.0.1", mode;
  int port = 1502, clients = 8;
  double seconds = 5;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "modbus_probe: " << a << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--host")
      host = next();
    else if (a == "--port")
      port = std::stoi(next());
    else if (a == "--clients")
      clients = std::stoi(next());
    else if (a == "--seconds")
      seconds = std::stod(next());
    else
      mode = a;
  }
  if (mode == "read") return read_all(host, port);
  if (mode == "load") return load(host, port, clients, seconds);
  std::cerr << "usage: modbus_probe [--host H] --port P read | load [--clients N] [--seconds S]\n";
  return 2;
}
