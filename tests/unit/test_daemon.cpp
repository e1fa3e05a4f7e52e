// brakefitd's parts in-process: configuration validation, the register map against its CSV, float
// packing, the SQLite store (incl. a full disk) and the Modbus TCP server over loopback with a
// real libmodbus client and raw sockets.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <set>
#include <thread>

#include "core/event_json.hpp"
#include "daemon/config.hpp"
#include "daemon/modbus_server.hpp"
#include "daemon/registers.hpp"
#include "daemon/store.hpp"
#include "daemon_test_util.hpp"
#include "test_util.hpp"

using namespace brakefit;
using namespace brakefit::daemon;
using brakefit::test::config_error;
using brakefit::test::kMinimalConfig;
using brakefit::test::make_event;
using brakefit::test::raw_connect;
using brakefit::test::raw_recv;
using brakefit::test::TempDir;

namespace {}  // namespace

TEST(Config, TheShippedExampleParses) {
  const Config c = parse_config(test::read_text(test::source_path("config/brakefitd.toml")),
                                "config/brakefitd.toml");
  EXPECT_EQ(c.kind, SourceKind::Gpio);
  EXPECT_EQ(c.modbus_tcp.port, 1502);
  EXPECT_FALSE(c.modbus_tcp.writable);
  EXPECT_EQ(c.gpio.offsets[2], 22u);
  EXPECT_DOUBLE_EQ(c.rtu.span_bar_per_count, 0.01);
  EXPECT_EQ(c.pipeline.methods.size(), 4u);
}

TEST(Config, ErrorsNameTheKey) {
  EXPECT_EQ(config_error(kMinimalConfig), "");
  EXPECT_NE(config_error(std::string(kMinimalConfig) + "[modbus_tcp]\nprot = 1502\n")
                .find("key 'modbus_tcp.prot': unknown key"),
            std::string::npos);
  EXPECT_NE(config_error(std::string(kMinimalConfig) + "[modbus_tcp]\nport = \"1502\"\n")
                .find("key 'modbus_tcp.port': expected an integer"),
            std::string::npos);
  EXPECT_NE(config_error(std::string(kMinimalConfig) + "[modbus_tcp]\nport = 70000\n")
                .find("key 'modbus_tcp.port': value 70000 is outside"),
            std::string::npos);
  EXPECT_NE(config_error(std::string(kMinimalConfig) + "[daemon]\nsensor_timeout_s = -1\n")
                .find("daemon.sensor_timeout_s"),
            std::string::npos);
  EXPECT_NE(config_error(std::string(kMinimalConfig) + "[bench]\n").find("test.toml:"),
            std::string::npos);
  EXPECT_NE(config_error("[source]\nkind = \"gpio\"\n[gpio]\n[bench]\n").find("'modbus_rtu'"),
            std::string::npos);
  EXPECT_NE(config_error("[source]\nkind = \"replay\"\n[bench]\n").find("source.file"),
            std::string::npos);
  EXPECT_NE(config_error(std::string(kMinimalConfig) + "[modbus_tcp]\nwrite_allow = [\"10.0.0\"]\n")
                .find("modbus_tcp.write_allow"),
            std::string::npos);
  EXPECT_NE(config_error(std::string(kMinimalConfig) + "[pipeline]\nmethods = [\"svm\"]\n")
                .find("pipeline.methods"),
            std::string::npos);
  EXPECT_NE(config_error(std::string(kMinimalConfig) + "[store]\nretention_days = 0\n")
                .find("store.retention_days"),
            std::string::npos);
}

TEST(Registers, ConfigCsvMatchesTheCompiledMap) {
  EXPECT_EQ(test::read_text(test::source_path("config/modbus_registers.csv")),
            format_register_csv())
      << "regenerate with: brakefitd --print-register-map > config/modbus_registers.csv";
}

TEST(Registers, NoOverlapsAndEverythingFitsItsTable) {
  std::set<std::pair<int, int>> used;
  for (const auto& r : register_map()) {
    const int table = r.table == RegTable::Input ? 0 : 1;
    const int size = table == 0 ? kInputRegisters : kHoldingRegisters;
    EXPECT_LE(r.address + r.count, size) << r.name;
    EXPECT_EQ(r.count, r.type == RegType::U16     ? 1
                       : r.type == RegType::Ascii ? r.count
                                                  : 2)
        << r.name;
    for (int a = r.address; a < r.address + r.count; ++a)
      EXPECT_TRUE(used.insert({table, a}).second) << r.name << " overlaps at " << a;
  }
  // The event block fits one FC 04 request (at most 125 registers), seq_begin first, seq last.
  EXPECT_LE(reg("event.seq").address - reg("event.seq_begin").address + 1, 125);
  for (const auto& r : register_map()) {
    if (std::string(r.name).starts_with("event.") && r.table == RegTable::Input) {
      EXPECT_LE(r.address, reg("event.seq").address);
    }
  }
}

TEST(Registers, Float32IsPackedAbcdByOurOwnCode) {
  const auto w = pack_f32_abcd(123456.0f);
  EXPECT_EQ(w[0], 0x47F1);
  EXPECT_EQ(w[1], 0x2000);
  EXPECT_EQ(unpack_f32_abcd(w[0], w[1]), 123456.0f);
  // Agrees with libmodbus's ABCD getter (its setters are byte-swapped in Debian's 3.1.6).
  const std::uint16_t regs[2] = {w[0], w[1]};
  EXPECT_EQ(modbus_get_float_abcd(regs), 123456.0f);
  const auto n = pack_f32_abcd(std::nanf(""));
  EXPECT_TRUE(std::isnan(unpack_f32_abcd(n[0], n[1])));
  const auto u = pack_u32(0x12345678u);
  EXPECT_EQ(u[0], 0x1234);
  EXPECT_EQ(u[1], 0x5678);
}

TEST(Store, CommitsEventsWithSamplesAndReadsThemBack) {
  TempDir tmp;
  StoreConfig c;
  c.path = (tmp.p / "events.db").string();
  c.min_free_mb = 0;
  {
    EventStore s(c, false);
    auto e = make_event(1, 500);
    const auto doc = event_json(e, "test", nullptr).dump();
    const auto id =
        s.commit(e, doc, "[bench]\nkind = \"roller\"\n", "WVW123", "replay x", "sha256:ab", 1000);
    ASSERT_TRUE(id);
    EXPECT_EQ(*id, 1);
    EXPECT_FALSE(s.degraded());
  }
  EventStore r(c, true);  // read-only, as `brakefit events` opens it
  ASSERT_EQ(r.count(), 1);
  const auto got = r.get(1);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->vehicle_id, "WVW123");
  EXPECT_EQ(got->end_reason, "switch_off_slip");
  EXPECT_TRUE(got->samples_stored);
  EXPECT_NE(got->result_json.find("brakefit.event/1"), std::string::npos);
  const auto samples = r.samples(1);
  const auto orig = make_event(1, 500).event.samples;
  ASSERT_EQ(samples.size(), orig.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    EXPECT_EQ(samples[i].t_ns, orig[i].t_ns);
    EXPECT_EQ(samples[i].v_wheel_mps, orig[i].v_wheel_mps);
    EXPECT_EQ(std::isnan(samples[i].force_n), std::isnan(orig[i].force_n));
    EXPECT_EQ(samples[i].sensor_fault, orig[i].sensor_fault);
  }
  EXPECT_EQ(r.integrity_check(), "ok");
}

TEST(Store, RetentionByCountAndAge) {
  TempDir tmp;
  StoreConfig c;
  c.path = (tmp.p / "events.db").string();
  c.min_free_mb = 0;
  c.max_events = 3;
  c.retention_days = 1;
  EventStore s(c, false);
  for (int i = 0; i < 5; ++i)
    ASSERT_TRUE(s.commit(make_event(i, 50), "{}", "", "", "t", "", 100'000 + i * 10));
  EXPECT_EQ(s.apply_retention(100'100), 2);  // count: the 3 newest stay
  EXPECT_EQ(s.count(), 3);
  EXPECT_FALSE(s.get(2));
  EXPECT_TRUE(s.get(5));
  EXPECT_EQ(s.apply_retention(100'000 + 86'400 + 35), 2);  // age: events 3 and 4 are too old
  EXPECT_EQ(s.count(), 1);
  EXPECT_TRUE(s.get(5));
  EXPECT_TRUE(s.samples(3).empty());  // their samples went with them (cascade)
}

TEST(Store, AFullDiskKeepsResultsDropsSamplesAndStaysConsistent) {
  TempDir tmp;
  StoreConfig c;
  c.path = (tmp.p / "events.db").string();
  c.min_free_mb = 0;
  EventStore s(c, false);
  ASSERT_TRUE(s.commit(make_event(1, 100), "{}", "", "", "t", "", 1));
  s.set_max_pages(12);  // the "disk" is nearly full: a 20000-sample blob does not fit
  const auto id = s.commit(make_event(2, 20000), "{\"big\":false}", "", "", "t", "", 2);
  ASSERT_TRUE(id) << s.error();
  EXPECT_TRUE(s.degraded());
  const auto got = s.get(*id);
  ASSERT_TRUE(got);
  EXPECT_FALSE(got->samples_stored);
  EXPECT_TRUE(s.samples(*id).empty());
  EXPECT_EQ(s.samples(1).size(), 100u);  // earlier data untouched
  EXPECT_EQ(s.integrity_check(), "ok");
  // Free space under min_free_mb: samples skipped up front.
  StoreConfig low = c;
  low.path = (tmp.p / "low.db").string();
  low.min_free_mb = 1e9;
  EventStore l(low, false);
  const auto lid = l.commit(make_event(3, 10), "{}", "", "", "t", "", 3);
  ASSERT_TRUE(lid);
  EXPECT_TRUE(l.degraded());
  EXPECT_FALSE(l.get(*lid)->samples_stored);
}

TEST(Store, UnwritablePathIsNamed) {
  StoreConfig c;
  c.path = "/proc/brakefit/events.db";
  try {
    EventStore s(c, false);
    FAIL();
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("/proc/brakefit/events.db"), std::string::npos);
  }
}

namespace {

struct Server {
  ModbusServer s;
  explicit Server(ModbusTcpConfig c)
      : s([&] {
          c.address = "127.0.0.1";
          c.port = 0;
          return c;
        }()) {
    s.start();
  }
};

modbus_t* client(int port) {
  modbus_t* m = modbus_new_tcp("127.0.0.1", port);
  modbus_set_response_timeout(m, 1, 0);
  EXPECT_EQ(modbus_connect(m), 0);
  return m;
}

}  // namespace

TEST(ModbusServer, PublishesPostedRegistersToALibmodbusClient) {
  Server srv(ModbusTcpConfig{});
  RegisterWrites w;
  w.u16("event.seq_begin", 7);
  w.f32("event.hybrid.B", 9.81);
  w.u32("event.id", 70000);
  w.u16("event.seq", 7);
  srv.s.post(std::move(w), std::chrono::steady_clock::now());
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  modbus_t* m = client(srv.s.port());
  std::uint16_t regs[125];
  const int base = reg("event.seq_begin").address;
  const int n = reg("event.seq").address - base + 1;
  ASSERT_EQ(modbus_read_input_registers(m, base, n, regs), n);
  EXPECT_EQ(regs[0], 7);
  EXPECT_EQ(regs[n - 1], 7);
  const int b = reg("event.hybrid.B").address - base;
  EXPECT_FLOAT_EQ(modbus_get_float_abcd(&regs[b]), 9.81f);
  const int id = reg("event.id").address - base;
  EXPECT_EQ((regs[id] << 16) | regs[id + 1], 70000);
  // Unset floats read NaN, the map version is set.
  EXPECT_TRUE(std::isnan(modbus_get_float_abcd(&regs[reg("event.som.B").address - base])));
  ASSERT_EQ(modbus_read_input_registers(m, 0, 1, regs), 1);
  EXPECT_EQ(regs[0], kMapVersion);
  EXPECT_EQ(srv.s.publish_latencies_us().size(), 1u);
  modbus_close(m);
  modbus_free(m);
}

TEST(ModbusServer, ReadOnlyByDefaultAndWritesOnlyFromTheAllowList) {
  {
    Server srv(ModbusTcpConfig{});
    modbus_t* m = client(srv.s.port());
    EXPECT_EQ(modbus_write_register(m, reg("command").address, kCmdAbort), -1);
    EXPECT_EQ(errno, EMBXILFUN);
    std::uint16_t v = 0;
    EXPECT_EQ(modbus_read_registers(m, reg("command").address, 1, &v), 1);  // reads still work
    EXPECT_TRUE(srv.s.take_commands().empty());
    modbus_close(m);
    modbus_free(m);
  }
  ModbusTcpConfig c;
  c.writable = true;
  c.write_allow = {"127.0.0.2"};  // not us
  Server srv(c);
  modbus_t* m = client(srv.s.port());
  EXPECT_EQ(modbus_write_register(m, reg("command").address, kCmdArm), -1);
  srv.s.set_write_policy(true, {"127.0.0.1"});
  ASSERT_EQ(modbus_write_register(m, reg("command").address, kCmdArm), 1);
  const std::uint16_t vid[8] = {0x5756, 0x5731, 0x3233, 0, 0, 0, 0, 0};  // "WVW123"
  ASSERT_EQ(modbus_write_registers(m, reg("vehicle_id").address, 8, vid), 8);
  // Out of the command range: libmodbus answers illegal data address.
  const std::uint16_t big[4] = {1, 2, 3, 4};
  EXPECT_EQ(modbus_write_registers(m, kHoldingRegisters - 2, 4, big), -1);
  const auto cmds = srv.s.take_commands();
  ASSERT_EQ(cmds.size(), 2u);
  EXPECT_EQ(cmds[0].command, kCmdArm);
  ASSERT_TRUE(cmds[1].vehicle_id);
  EXPECT_EQ(*cmds[1].vehicle_id, "WVW123");
  std::uint16_t count = 0;
  ASSERT_EQ(modbus_read_registers(m, reg("command_count").address, 1, &count), 1);
  EXPECT_EQ(count, 1);
  modbus_close(m);
  modbus_free(m);
}

TEST(ModbusServer, MalformedFramesAreRefusedAndTheServerCarriesOn) {
  Server srv(ModbusTcpConfig{});
  // Protocol id 1: not Modbus, the connection is dropped.
  int fd = raw_connect(srv.s.port());
  const std::uint8_t bad_pid[] = {0, 1, 0, 1, 0, 6, 1, 4, 0, 0, 0, 1};
  ::send(fd, bad_pid, sizeof bad_pid, 0);
  EXPECT_TRUE(raw_recv(fd, 500).empty());
  ::close(fd);
  // A read whose MBAP length claims a longer PDU than a read has (a write smuggled behind it):
  // answered with an exception, never executed.
  fd = raw_connect(srv.s.port());
  const std::uint8_t smuggle[] = {0, 2, 0, 0, 0, 11, 1, 4, 0, 0, 0, 1, 6, 0, 0, 0, 2};
  ::send(fd, smuggle, sizeof smuggle, 0);
  auto r = raw_recv(fd, 500);
  ASSERT_EQ(r.size(), 9u);
  EXPECT_EQ(r[7], 0x84);  // FC 4 | 0x80: exception
  EXPECT_EQ(r[8], MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
  // FC 16 whose byte count disagrees with the length.
  const std::uint8_t fc16[] = {0, 3, 0, 0, 0, 9, 1, 16, 0, 0, 0, 1, 40, 0, 1};
  ::send(fd, fc16, sizeof fc16, 0);
  r = raw_recv(fd, 500);
  ASSERT_EQ(r.size(), 9u);
  EXPECT_EQ(r[7], 0x90);
  // An absurd length (over 254): dropped.
  const std::uint8_t huge[] = {0, 4, 0, 0, 0x10, 0, 1, 4};
  ::send(fd, huge, sizeof huge, 0);
  EXPECT_TRUE(raw_recv(fd, 500).empty());
  ::close(fd);
  EXPECT_GE(srv.s.stats().malformed.load(), 2u);
  // Still serving.
  modbus_t* m = client(srv.s.port());
  std::uint16_t v = 0;
  EXPECT_EQ(modbus_read_input_registers(m, 0, 1, &v), 1);
  modbus_close(m);
  modbus_free(m);
}

TEST(ModbusServer, ATricklingClientDoesNotStallTheOthers) {
  Server srv(ModbusTcpConfig{});
  const int slow = raw_connect(srv.s.port());
  const std::uint8_t req[] = {0, 9, 0, 0, 0, 6, 1, 4, 0, 0, 0, 1};
  ::send(slow, req, 3, 0);  // the first bytes, then nothing for a while
  modbus_t* m = client(srv.s.port());
  std::uint16_t v = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < 20; ++i) ASSERT_EQ(modbus_read_input_registers(m, 0, 1, &v), 1);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(ms, 400.0);  // 20 requests; a stalled loop would need 0.5 s per byte of the slow one
  ::send(slow, req + 3, sizeof req - 3, 0);  // the rest arrives: it is answered too
  const auto r = raw_recv(slow, 500);
  ASSERT_EQ(r.size(), 11u);
  EXPECT_EQ(r[7], 4);
  ::close(slow);
  modbus_close(m);
  modbus_free(m);
}

TEST(ModbusServer, AHundredClientsAtOnceAreAllServed) {
  ModbusTcpConfig c;
  c.max_clients = 128;
  c.max_clients_per_address = 128;  // all from 127.0.0.1 here
  Server srv(c);
  std::vector<int> fds;
  for (int i = 0; i < 100; ++i) fds.push_back(raw_connect(srv.s.port()));
  for (std::size_t i = 0; i < fds.size(); ++i) {
    const std::uint8_t req[] = {0, static_cast<std::uint8_t>(i), 0, 0, 0, 6, 1, 4, 0, 0, 0, 2};
    ASSERT_EQ(::send(fds[i], req, sizeof req, 0), static_cast<ssize_t>(sizeof req));
  }
  int ok = 0;
  for (std::size_t i = 0; i < fds.size(); ++i) {
    const auto r = raw_recv(fds[i], 2000);
    if (r.size() == 13 && r[1] == static_cast<std::uint8_t>(i) && r[7] == 4) ++ok;
    ::close(fds[i]);
  }
  EXPECT_EQ(ok, 100);
  EXPECT_EQ(srv.s.stats().rejected.load(), 0u);
}
