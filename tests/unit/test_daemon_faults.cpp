// The daemon's promises under faults, in-process: who gets a Modbus connection when one host holds
// every slot it may, the store's reasons for not opening, records that wait for the store (CBOR
// spill files, their order, a restart finding them), and the last-event block rebuilt from a
// stored row (what a restart restores).
#include <gtest/gtest.h>
#include <modbus.h>
#include <sqlite3.h>
#include <sys/stat.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/event_json.hpp"
#include "daemon/admission.hpp"
#include "daemon/event_block.hpp"
#include "daemon/modbus_gate.hpp"
#include "daemon/modbus_server.hpp"
#include "daemon/pending.hpp"
#include "daemon/registers.hpp"
#include "daemon/store.hpp"
#include "daemon_test_util.hpp"

using namespace brakefit;
using namespace brakefit::daemon;
using brakefit::test::make_event;
using brakefit::test::make_test_record;
using brakefit::test::raw_connect;
using brakefit::test::raw_recv;
using brakefit::test::TempDir;
using Clock = std::chrono::steady_clock;

namespace {

std::vector<ConnectionView> conns(const std::vector<std::pair<std::string, int>>& ip_idle_s) {
  const auto now = Clock::now();
  std::vector<ConnectionView> v;
  v.reserve(ip_idle_s.size());
  for (const auto& [ip, idle] : ip_idle_s) v.push_back({ip, now - std::chrono::seconds(idle)});
  return v;
}

}  // namespace

TEST(Admission, OneAddressIsCappedAndANewAddressAlwaysGetsASlot) {
  // Under both limits: admitted, nothing evicted.
  auto a = admit_connection(conns({{"10.0.0.1", 1}}), "10.0.0.1", 4, 2);
  EXPECT_TRUE(a.admit);
  EXPECT_FALSE(a.evict);
  // The address holds its limit: refused.
  a = admit_connection(conns({{"10.0.0.1", 1}, {"10.0.0.1", 2}}), "10.0.0.1", 4, 2);
  EXPECT_FALSE(a.admit);
  // Full: the idlest connection of the busiest address makes room for the newcomer.
  a = admit_connection(conns({{"10.0.0.1", 5}, {"10.0.0.1", 9}, {"10.0.0.1", 1}, {"10.0.0.2", 99}}),
                       "10.0.0.3", 4, 3);
  ASSERT_TRUE(a.admit);
  ASSERT_TRUE(a.evict);
  EXPECT_EQ(*a.evict, 1u);  // 10.0.0.1 idle 9 s, not 10.0.0.2's (it holds only one)
  // Full and the newcomer holds some: another address's connection goes, never its own.
  a = admit_connection(conns({{"10.0.0.1", 5}, {"10.0.0.2", 1}}), "10.0.0.2", 2, 2);
  ASSERT_TRUE(a.admit);
  EXPECT_EQ(*a.evict, 0u);
  // Only the newcomer's own connections are open (per-address limit >= max_clients): refused.
  a = admit_connection(conns({{"10.0.0.1", 5}, {"10.0.0.1", 1}}), "10.0.0.1", 2, 5);
  EXPECT_FALSE(a.admit);
}

TEST(ModbusServer, AHostHoldingEveryConnectionItMayDoesNotLockOthersOut) {
  ModbusTcpConfig c;
  c.address = "127.0.0.1";
  c.port = 0;
  c.max_clients = 8;
  c.max_clients_per_address = 8;  // one host may take every slot
  ModbusServer srv(c);
  srv.start();
  std::vector<int> hog;
  hog.reserve(12);
  for (int i = 0; i < 12; ++i) hog.push_back(raw_connect(srv.port(), "127.0.0.1"));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  // A new host: connected, asked, answered within 100 ms.
  const auto t0 = Clock::now();
  const int fd = raw_connect(srv.port(), "127.0.0.2");
  const std::uint8_t req[] = {0, 7, 0, 0, 0, 6, 1, 4, 0, 0, 0, 1};
  ASSERT_EQ(::send(fd, req, sizeof req, 0), static_cast<ssize_t>(sizeof req));
  const auto r = raw_recv(fd, 1000);
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  ASSERT_EQ(r.size(), 11u);
  EXPECT_EQ(r[1], 7);
  EXPECT_LT(ms, 100.0);
  std::printf("new host answered in %.2f ms while another held every slot\n", ms);
  // 4 of the hog's 12 were refused, 1 evicted for the newcomer.
  EXPECT_EQ(srv.stats().rejected.load(), 5u);
  EXPECT_EQ(srv.stats().clients.load(), 8);
  for (int h : hog) ::close(h);
  ::close(fd);
  srv.stop();
}

TEST(ModbusServer, OneAddressIsLimitedAndTheRejectionsAreInARegister) {
  ModbusTcpConfig c;
  c.address = "127.0.0.1";
  c.port = 0;
  c.max_clients = 16;
  c.max_clients_per_address = 3;
  ModbusServer srv(c);
  srv.start();
  std::vector<int> fds;
  fds.reserve(5);
  for (int i = 0; i < 5; ++i) fds.push_back(raw_connect(srv.port(), "127.0.0.1"));
  // The server refuses the 4th and 5th when its loop accepts them, which can be after it has
  // answered the first client (a race the test once lost under load): wait for both refusals.
  for (int i = 0; i < 200 && srv.stats().rejected.load() < 2; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_EQ(srv.stats().rejected.load(), 2u);
  int answered = 0;
  for (int fd : fds) {
    const std::uint8_t req[] = {0, 1, 0, 0, 0, 6, 1, 4, 0, 33, 0, 2};  // modbus_rejected
    ::send(fd, req, sizeof req, MSG_NOSIGNAL);
    const auto r = raw_recv(fd, 1000);
    if (r.size() == 13) {
      ++answered;
      EXPECT_EQ((r[9] << 24) | (r[10] << 16) | (r[11] << 8) | r[12], 2);
    }
  }
  EXPECT_EQ(answered, 3);
  EXPECT_EQ(reg("modbus_rejected").address, 33);
  for (int fd : fds) ::close(fd);
  srv.stop();
}

TEST(Store, ASystemReasonIsNamedNotJustUnableToOpen) {
  TempDir tmp;
  std::ofstream(tmp.p / "file") << "x";
  for (const auto& [path, reason] : std::vector<std::pair<std::string, std::string>>{
           {(tmp.p / "file" / "events.db").string(), "Not a directory"},
           {(tmp.p / "file" / "sub" / "events.db").string(), "Not a directory"},
           {tmp.p.string(), "is a directory"}}) {
    StoreConfig c;
    c.path = path;
    try {
      EventStore s(c, false);
      ADD_FAILURE() << path;
    } catch (const std::exception& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find(path), std::string::npos) << m;
      EXPECT_NE(m.find(reason), std::string::npos) << m;
    }
  }
  if (::geteuid() != 0) {  // root writes anywhere: EACCES only reachable as a user
    std::filesystem::create_directories(tmp.p / "ro");
    ::chmod((tmp.p / "ro").c_str(), 0555);
    StoreConfig c;
    c.path = (tmp.p / "ro" / "events.db").string();
    try {
      EventStore s(c, false);
      ADD_FAILURE();
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find("Permission denied"), std::string::npos) << e.what();
    }
  }
}

TEST(Store, ARecordRoundTripsThroughItsSpillFormat) {
  const EventRecord r = make_test_record(3, 40);
  const EventRecord back = record_from_cbor(record_to_cbor(r), "x.cbor");
  EXPECT_EQ(back.result_json, r.result_json);
  EXPECT_EQ(back.samples_blob, r.samples_blob);
  EXPECT_EQ(back.sample_count, 40);
  EXPECT_EQ(back.t_end_ns, r.t_end_ns);
  EXPECT_EQ(back.vehicle_id, "V1");
  std::string cut = record_to_cbor(r);
  cut.resize(cut.size() / 2);
  for (const std::string& bad : {cut, std::string("garbage"), std::string()}) {
    try {
      record_from_cbor(bad, "dir/7.cbor");
      ADD_FAILURE();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("dir/7.cbor"), std::string::npos);
    }
  }
}

TEST(Store, LastAndFindSeeWhatWasCommitted) {
  TempDir tmp;
  StoreConfig c;
  c.path = (tmp.p / "e.db").string();
  c.min_free_mb = 0;
  EventStore s(c, false);
  EXPECT_FALSE(s.last());
  const auto r1 = make_test_record(1), r2 = make_test_record(2);
  EXPECT_EQ(s.commit(r1), 1);
  EXPECT_EQ(s.commit(r2), 2);
  EXPECT_EQ(s.last()->id, 2);
  EXPECT_EQ(s.find(r1), 1);
  EXPECT_FALSE(s.find(make_test_record(1)));  // the same event made again is another record
  EXPECT_NE(make_test_record(1).uid, make_test_record(1).uid);
}

TEST(Store, AStoreMadeBeforeTheUidColumnGetsIt) {
  TempDir tmp;
  const std::string path = (tmp.p / "old.db").string();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(
      sqlite3_exec(db,
                   "CREATE TABLE events (id INTEGER PRIMARY KEY AUTOINCREMENT, created_unix_s "
                   "INTEGER NOT NULL, source TEXT NOT NULL, vehicle_id TEXT NOT NULL, "
                   "pipeline_event_id INTEGER NOT NULL, bench TEXT NOT NULL, t_start_ns "
                   "INTEGER NOT NULL, t_end_ns INTEGER NOT NULL, end_reason TEXT NOT NULL, "
                   "flags TEXT NOT NULL, points INTEGER NOT NULL, model_hash TEXT NOT NULL, "
                   "samples_stored INTEGER NOT NULL, calibration_toml TEXT NOT NULL, "
                   "result_json TEXT NOT NULL);"
                   "INSERT INTO events VALUES (1, 1, 's', '', 1, 'roller', 0, 1, 'x', '', 0, "
                   "'', 0, '', '{}');",
                   nullptr, nullptr, nullptr),
      SQLITE_OK);
  sqlite3_close(db);
  StoreConfig c;
  c.path = path;
  c.min_free_mb = 0;
  EventStore s(c, false);
  const auto r = make_test_record(2);
  EXPECT_EQ(s.commit(r), 2);
  EXPECT_EQ(s.find(r), 2);
  EXPECT_EQ(s.count(), 2);
}

TEST(Store, ALockHeldByAnotherConnectionFailsTheCommitQuicklyAndItSucceedsAfter) {
  TempDir tmp;
  StoreConfig c;
  c.path = (tmp.p / "e.db").string();
  c.min_free_mb = 0;
  EventStore s(c, false, 50);
  sqlite3* other = nullptr;
  ASSERT_EQ(sqlite3_open(c.path.c_str(), &other), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(other, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr), SQLITE_OK);
  const auto t0 = Clock::now();
  EXPECT_FALSE(s.commit(make_test_record(1)));
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 1.0);
  EXPECT_NE(s.error().find("locked"), std::string::npos) << s.error();
  sqlite3_exec(other, "COMMIT", nullptr, nullptr, nullptr);
  sqlite3_close(other);
  EXPECT_EQ(s.commit(make_test_record(1)), 1);
}

TEST(Pending, SpillsInOrderAndARestartFindsThemOldestFirst) {
  TempDir tmp;
  const std::string dir = (tmp.p / "e.db.spill").string();
  {
    PendingEvents p(dir, 1, 8);
    p.push(make_test_record(1), "");
    p.push(make_test_record(2), "");
    EXPECT_EQ(p.spilled(), 0u);  // held until the store fails
    p.spill_excess();            // over hold_in_memory 1: record 1 is spilled
    p.push(make_test_record(3), "");
    p.spill_excess();  // record 2 spilled
    EXPECT_EQ(p.size(), 3u);
    EXPECT_EQ(p.spilled(), 2u);
    ASSERT_TRUE(p.front());
    EXPECT_EQ(p.front()->pipeline_event_id, 1);
    p.pop();
    EXPECT_EQ(p.front()->pipeline_event_id, 2);
    EXPECT_EQ(p.spill_all(), 0u);  // a clean stop: record 3 joins the files
    EXPECT_EQ(p.spilled(), 2u);
  }
  // A corrupt file among them is moved aside, not a crash and not a silent stop.
  std::ofstream(std::filesystem::path(dir) / "00000000000000000000.cbor") << "not cbor";
  PendingEvents again(dir, 0, 8);
  EXPECT_EQ(again.adopt_spilled(), 3u);
  ASSERT_TRUE(again.front());
  EXPECT_EQ(again.front()->pipeline_event_id, 2);
  EXPECT_TRUE(
      std::filesystem::exists(std::filesystem::path(dir) / "00000000000000000000.cbor.bad"));
  again.pop();
  EXPECT_EQ(again.front()->pipeline_event_id, 3);
  again.pop();
  EXPECT_EQ(again.front(), nullptr);
  EXPECT_EQ(again.size(), 0u);
}

TEST(Pending, WhenSpillingFailsTooEventsBeyondTheCapAreCountedLost) {
  TempDir tmp;
  std::ofstream(tmp.p / "file") << "x";
  PendingEvents p((tmp.p / "file" / "spill").string(), 0, 2);  // cannot create a directory there
  for (int i = 1; i <= 5; ++i) {
    p.push(make_test_record(i), "");
    p.spill_excess();
  }
  EXPECT_EQ(p.size(), 2u);
  EXPECT_EQ(p.lost(), 3u);
  EXPECT_EQ(p.front()->pipeline_event_id, 4);
}

TEST(EventBlock, IsBuiltFromTheStoredDocumentAndSeqFollowsTheRowId) {
  auto e = make_event(5, 100);
  e.event.flags = {"aborted"};
  const auto doc = event_json(e, "test", nullptr).dump();
  const RegisterWrites w = event_block(doc, 70000, false);
  std::map<std::uint16_t, std::uint16_t> regs(w.input.begin(), w.input.end());
  EXPECT_EQ(w.input.front().first, reg("event.seq_begin").address);
  EXPECT_EQ(w.input.back().first, reg("event.seq").address);
  EXPECT_EQ(regs[reg("event.seq").address], 70000 & 0xFFFF);
  EXPECT_EQ(regs[reg("event.id").address + 1], 70000 & 0xFFFF);
  EXPECT_EQ(regs[reg("event.flags").address],
            kFlagAborted | kFlagNotFitted | kFlagSamplesNotStored);
  EXPECT_EQ(regs[reg("event.points").address], 100);
  const auto pf = reg("event.peak_force_n").address;
  EXPECT_FLOAT_EQ(unpack_f32_abcd(regs[pf], regs[pf + 1]), static_cast<float>(66.7 * 0.05 * 99));
  const auto b = reg("event.lm.B").address;
  EXPECT_TRUE(std::isnan(unpack_f32_abcd(regs[b], regs[b + 1])));
  EXPECT_THROW(event_block("{\"schema\":\"other\"}", 1, true), std::exception);
  // A least-squares parameter at its bound raises bit 6; the same on a SOM result does not.
  auto e2 = make_event(6, 100);
  MethodResult lm;
  lm.method = Method::Lm;
  lm.params = {10, 0.3, 5000, -4, 0, 0};
  lm.at_bound = {"C"};
  MethodResult som = lm;
  som.method = Method::Som;
  e2.results = {som};
  auto flags_of = [&](const pipeline::EventResult& ev) {
    const RegisterWrites w2 = event_block(event_json(ev, "test", nullptr).dump(), 2, true);
    std::map<std::uint16_t, std::uint16_t> r(w2.input.begin(), w2.input.end());
    return r[reg("event.flags").address];
  };
  EXPECT_EQ(flags_of(e2) & kFlagAtBound, 0);
  e2.results = {som, lm};
  EXPECT_EQ(flags_of(e2) & kFlagAtBound, kFlagAtBound);
}

TEST(ModbusGate, CutsRequestsAndAnswersWhatLibmodbusWouldSleepOn) {
  auto req = [](const std::vector<std::uint8_t>& pdu) {
    std::vector<std::uint8_t> a(7 + pdu.size(), 0);
    a[1] = 1;
    a[5] = static_cast<std::uint8_t>(pdu.size() + 1);
    a[6] = 1;
    for (std::size_t i = 0; i < pdu.size(); ++i) a[7 + i] = pdu[i];
    return a;
  };
  auto gate = [](const std::vector<std::uint8_t>& a, bool allowed = false) {
    return gate_request(a.data(), a.size(), allowed);
  };
  EXPECT_EQ(gate(req({4, 0, 100, 0, 69})).result, GateResult::Pass);
  EXPECT_EQ(gate(req({4, 0, 100, 0, 69})).total, 12u);
  auto partial = req({4, 0, 100, 0, 69});
  partial.pop_back();
  EXPECT_EQ(gate(partial).result, GateResult::NeedMore);
  auto lying = req({4, 0, 100, 0, 69});
  lying[5] = 255;
  EXPECT_EQ(gate(lying).result, GateResult::Drop);
  for (const auto& [pdu, exc] : std::vector<std::pair<std::vector<std::uint8_t>, int>>{
           {{4, 0, 0, 0, 0}, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE},               // 0 registers
           {{3, 0, 0, 0, 126}, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE},             // 126 registers
           {{1, 0, 0, 0x07, 0xD1}, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE},         // 2001 coils
           {{5, 0, 0, 0x12, 0x34}, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE},         // coil value
           {{16, 0, 0, 0, 2, 3, 1, 2, 3}, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE},  // byte count
           {{0x2B, 0x0E, 1, 0}, MODBUS_EXCEPTION_ILLEGAL_FUNCTION},              // unknown function
           {{6, 0, 0, 0, 1}, MODBUS_EXCEPTION_ILLEGAL_FUNCTION},  // write, not allowed
       }) {
    const auto g = gate(req(pdu));
    EXPECT_EQ(g.result, GateResult::Exception) << int(pdu[0]);
    EXPECT_EQ(g.exception, exc) << int(pdu[0]);
  }
  EXPECT_EQ(gate(req({6, 0, 0, 0, 1}), true).result, GateResult::Pass);
  EXPECT_EQ(gate(req({16, 0, 2, 0, 2, 4, 0x41, 0x42, 0x31, 0x32}), true).result, GateResult::Pass);
}

TEST(ModbusServer, RequestsLibmodbusWouldSleepOnDoNotStallOtherClients) {
  ModbusTcpConfig c;
  c.address = "127.0.0.1";
  c.port = 0;
  ModbusServer srv(c);
  srv.start();
  const int bad = raw_connect(srv.port(), "127.0.0.1");
  const int good = raw_connect(srv.port(), "127.0.0.2");
  std::vector<std::uint8_t> burst;
  for (std::uint8_t i = 0; i < 10; ++i)  // "read 0 registers": libmodbus sleeps 0.5 s on each
    burst.insert(burst.end(), {0, i, 0, 0, 0, 6, 1, 4, 0, 0, 0, 0});
  ASSERT_EQ(::send(bad, burst.data(), burst.size(), 0), static_cast<ssize_t>(burst.size()));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const auto t0 = Clock::now();
  const std::uint8_t req[] = {0, 42, 0, 0, 0, 6, 1, 4, 0, 0, 0, 1};
  ASSERT_EQ(::send(good, req, sizeof req, 0), static_cast<ssize_t>(sizeof req));
  const auto r = raw_recv(good, 3000);
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  ASSERT_EQ(r.size(), 11u);
  EXPECT_LT(ms, 100.0);
  const auto e = raw_recv(bad, 1000);  // the bad client got its exceptions at once
  ASSERT_GE(e.size(), 9u);
  EXPECT_EQ(e[7], 0x84);
  EXPECT_EQ(e[8], MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
  ::close(bad);
  ::close(good);
  srv.stop();
}
