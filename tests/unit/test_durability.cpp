// The store never loses a finished event, in-process: journal files that cannot collide, spill
// files read with bounded size, type and depth (one bad file never strands the others), the
// write-ahead log read as SQLite's recovery will and kept aside when it does not end cleanly,
// every commit checkpointed into the main file, one daemon per store, the station software's
// connection never evicted, and events that end on implausible data or at their maximum length.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>

#include "core/event_json.hpp"
#include "core/exit_codes.hpp"
#include "daemon/admission.hpp"
#include "daemon/config.hpp"
#include "daemon/event_block.hpp"
#include "daemon/instance_lock.hpp"
#include "daemon/pending.hpp"
#include "daemon/registers.hpp"
#include "daemon/store.hpp"
#include "daemon/wal_check.hpp"
#include "daemon_test_util.hpp"

using namespace brakefit;
using namespace brakefit::daemon;
using brakefit::test::config_error;
using brakefit::test::kMinimalConfig;
using brakefit::test::make_event;
using brakefit::test::make_test_record;
using brakefit::test::TempDir;
namespace fs = std::filesystem;

namespace {

std::size_t count_ext(const fs::path& dir, const std::string& ext) {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir)) n += e.path().extension() == ext;
  return n;
}

std::int64_t rows(const std::string& db) {
  sqlite3* h = nullptr;
  EXPECT_EQ(sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  std::int64_t n = -1;
  if (sqlite3_prepare_v2(h, "SELECT COUNT(*) FROM events", -1, &st, nullptr) == SQLITE_OK &&
      sqlite3_step(st) == SQLITE_ROW)
    n = sqlite3_column_int64(st, 0);
  sqlite3_finalize(st);
  sqlite3_close(h);
  return n;
}

/// A WAL-mode database with `n` committed transactions left in its log (no checkpoint), copied
/// as a crash would leave it.
void wal_with_commits(const fs::path& dir, int n) {
  const std::string live = (dir / "live.db").string();
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(live.c_str(), &h), SQLITE_OK);
  sqlite3_exec(h,
               "PRAGMA journal_mode=WAL; PRAGMA wal_autocheckpoint=0;"
               "CREATE TABLE other (id INTEGER PRIMARY KEY, x BLOB)",
               nullptr, nullptr, nullptr);
  for (int i = 0; i < n; ++i)
    sqlite3_exec(h, "INSERT INTO other (x) VALUES (randomblob(3000))", nullptr, nullptr, nullptr);
  fs::copy_file(live, dir / "crashed.db");
  fs::copy_file(live + "-wal", dir / "crashed.db-wal");
  sqlite3_close(h);
}

}  // namespace

TEST(Config, TheDurabilityKeysAreCheckedAndNamed) {
  for (const auto& [text, key] : std::vector<std::pair<std::string, std::string>>{
           {"[modbus_tcp]\nprotected = [\"station\"]\n", "modbus_tcp.protected"},
           {"[pipeline]\nmax_event_s = 0.05\n", "pipeline.max_event_s"},
           {"[pipeline]\nmin_speed_mps = 1\n", "pipeline.min_speed_mps"},
           {"[pipeline]\nmax_pressure_bar = 1\n", "pipeline.max_pressure_bar"},
           {"[store]\nspill_dir = 5\n", "store.spill_dir"}})
    EXPECT_NE(config_error(std::string(kMinimalConfig) + text).find(key), std::string::npos)
        << text;
  const Config c = parse_config(std::string(kMinimalConfig) +
                                    "[modbus_tcp]\nprotected = [\"10.0.0.9\"]\n"
                                    "[pipeline]\nmax_event_s = 30\n[store]\nspill_dir = \"/j\"\n",
                                "test.toml");
  EXPECT_EQ(c.modbus_tcp.protect, std::vector<std::string>{"10.0.0.9"});
  EXPECT_DOUBLE_EQ(c.pipeline.events.max_event_s, 30.0);
  EXPECT_EQ(c.store.spill_dir, "/j");
  EXPECT_TRUE(c.pipeline.defer_fit);
}

TEST(Journal, TwoWritersOnOneDirectoryNeverOverwriteEachOthersFiles) {
  TempDir tmp;
  const std::string dir = (tmp.p / "e.db.spill").string();
  PendingEvents a(dir, 0, 8), b(dir, 0, 8);  // both start at sequence 1
  const auto pa = a.journal(make_test_record(1));
  const auto pb = b.journal(make_test_record(2));
  ASSERT_FALSE(pa.empty());
  ASSERT_FALSE(pb.empty());
  EXPECT_NE(pa, pb);
  EXPECT_EQ(count_ext(dir, ".cbor"), 2u);
  PendingEvents again(dir, 0, 8);
  EXPECT_EQ(again.adopt_spilled(), 2u);
}

TEST(Journal, AJournaledEventIsOnDiskBeforeItIsFittedAndGoesOnlyWithItsCommit) {
  TempDir tmp;
  const std::string dir = (tmp.p / "e.db.spill").string();
  auto closed = make_event(7, 60);
  closed.results.clear();
  EventRecord unfitted = make_record(closed, "", "[bench]\n", "V1", "test", "h", 1007);
  EXPECT_FALSE(fitted(unfitted));
  PendingEvents p(dir, 0, 8);
  const std::string path = p.journal(unfitted);
  ASSERT_TRUE(fs::exists(path));
  {
    // The process dies here: the next start finds the closed event, whole.
    PendingEvents next(dir, 0, 8);
    ASSERT_EQ(next.adopt_spilled(), 1u);
    const EventRecord* r = next.front();
    ASSERT_TRUE(r);
    EXPECT_FALSE(fitted(*r));
    EXPECT_EQ(r->uid, unfitted.uid);
    const auto e = event_from_record(*r);
    EXPECT_EQ(e.event_id, 7);
    EXPECT_EQ(e.samples.size(), 60u);
    EXPECT_EQ(e.end_reason, "switch_off_slip");
  }
  EventRecord done = make_test_record(7, 60);
  done.uid = unfitted.uid;
  p.push(done, path);
  EXPECT_EQ(p.spilled(), 1u);
  p.pop();  // committed
  EXPECT_FALSE(fs::exists(path));
}

TEST(SpillFiles, CraftedFilesAreRefusedWithoutCrashHangOrGrowthAndNeverStrandTheValidOnes) {
  TempDir tmp;
  const fs::path dir = tmp.p / "e.db.spill";
  fs::create_directories(dir);
  {
    std::ofstream deep(dir / "00000000000000000001-deep.cbor", std::ios::binary);
    deep << std::string(1 << 20, '\x81') << '\x00';  // a million nested one-element arrays
  }
  ASSERT_EQ(::mkfifo((dir / "00000000000000000002-fifo.cbor").c_str(), 0600), 0);
  fs::create_symlink("/dev/zero", dir / "00000000000000000003-zero.cbor");
  std::ofstream(dir / "00000000000000000004-text.cbor") << "not cbor";
  PendingEvents writer(dir.string(), 0, 8);
  for (int i = 0; i < 4; ++i)
    writer.journal(make_test_record(100));  // sequence 1-4 too: sorted after
  const auto valid = writer.journal(make_test_record(42));
  ASSERT_FALSE(valid.empty());

  PendingEvents p(dir.string(), 0, 8);
  const auto t0 = std::chrono::steady_clock::now();
  p.adopt_spilled();
  const EventRecord* r = nullptr;
  std::vector<int> ids;
  while ((r = p.front())) {
    ids.push_back(static_cast<int>(r->pipeline_event_id));
    p.pop();
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  EXPECT_EQ(ids, (std::vector<int>{100, 100, 100, 100, 42}));
  for (const char* bad : {"00000000000000000001-deep.cbor", "00000000000000000002-fifo.cbor",
                          "00000000000000000003-zero.cbor", "00000000000000000004-text.cbor"}) {
    EXPECT_TRUE(fs::exists(fs::symlink_status(dir / (std::string(bad) + ".bad")))) << bad;
  }
  EXPECT_TRUE(fs::exists("/dev/zero"));  // the link was moved, never followed
}

TEST(SpillFiles, AFileBeyondTheSizeBoundIsNotRead) {
  TempDir tmp;
  PendingEvents p((tmp.p / "s").string(), 0, 8);
  const auto path = p.journal(make_test_record(1));
  const auto size = fs::file_size(path);
  EXPECT_EQ(read_spill_file(path, size).pipeline_event_id, 1);
  try {
    read_spill_file(path, size - 1);
    FAIL() << "read past the bound";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("more than a spill file holds"), std::string::npos);
  }
}

TEST(Wal, ACleanLogIsReadToItsLastCommitAndATornOrGarbageOneIsNamed) {
  TempDir tmp;
  wal_with_commits(tmp.p, 3);
  const std::string wal = (tmp.p / "crashed.db-wal").string();
  auto w = check_wal(wal);
  EXPECT_TRUE(w.present);
  EXPECT_EQ(w.commits, 4u);  // the CREATE TABLE and three inserts
  EXPECT_EQ(w.problem, "");
  EXPECT_EQ(w.used_bytes, w.bytes);
  fs::resize_file(wal, w.bytes - 1000);  // torn: the last transaction's commit frame cut
  w = check_wal(wal);
  EXPECT_EQ(w.commits, 3u);
  EXPECT_NE(w.problem.find("cut short"), std::string::npos) << w.problem;
  {
    std::fstream f(wal, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(32 + 24 + 100);  // inside the first frame's page
    f << "garbage garbage garbage";
  }
  w = check_wal(wal);
  EXPECT_NE(w.problem.find("checksum"), std::string::npos) << w.problem;
  EXPECT_EQ(w.commits, 0u);
  {
    std::ofstream f(wal, std::ios::binary | std::ios::trunc);
    f << std::string(4096, 'x');
  }
  EXPECT_NE(check_wal(wal).problem.find("header"), std::string::npos);
  EXPECT_FALSE(check_wal((tmp.p / "none-wal").string()).present);
}

TEST(Wal, AStoreOpenedOnALogThatDoesNotEndCleanlyKeepsItAside) {
  TempDir tmp;
  wal_with_commits(tmp.p, 3);
  const std::string wal = (tmp.p / "crashed.db-wal").string();
  fs::resize_file(wal, fs::file_size(wal) - 1000);
  StoreConfig c;
  c.path = (tmp.p / "crashed.db").string();
  c.min_free_mb = 0;
  { EventStore s(c, false); }
  std::size_t kept = 0;
  for (const auto& e : fs::directory_iterator(tmp.p))
    kept += e.path().filename().string().rfind("crashed.db-wal.kept-", 0) == 0;
  EXPECT_EQ(kept, 1u);
}

TEST(Wal, EveryCommitReachesTheMainFile) {
  TempDir tmp;
  StoreConfig c;
  c.path = (tmp.p / "e.db").string();
  c.min_free_mb = 0;
  EventStore s(c, false);
  for (int i = 1; i <= 3; ++i) ASSERT_TRUE(s.commit(make_test_record(i)));
  // A copy of the main file alone (a backup that forgot -wal) holds all three.
  fs::copy_file(c.path, tmp.p / "backup.db");
  EXPECT_EQ(rows((tmp.p / "backup.db").string()), 3);
}

TEST(InstanceLock, ASecondDaemonOnOneStoreIsRefusedWithExit75NamingTheHolder) {
  TempDir tmp;
  const std::string store = (tmp.p / "e.db").string();
  {
    InstanceLock first(store);
    try {
      InstanceLock second(store);
      FAIL() << "two daemons on one store";
    } catch (const ExitError& e) {
      EXPECT_EQ(e.code, kExitTempFail);
      EXPECT_NE(std::string(e.what()).find(fmt::format("pid {}", ::getpid())), std::string::npos)
          << e.what();
    }
  }
  EXPECT_NO_THROW(InstanceLock again(store));  // released with its holder
}

TEST(Admission, AProtectedAddressIsNeverEvictedByAFloodOfNewOnes) {
  using Clock = std::chrono::steady_clock;
  const auto now = Clock::now();
  // The station software's connection is the idlest; 3 flooders fill the rest.
  std::vector<ConnectionView> open{{"10.0.0.9", now - std::chrono::seconds(50)},
                                   {"10.0.1.1", now},
                                   {"10.0.1.2", now},
                                   {"10.0.1.3", now}};
  const std::vector<std::string> protect{"10.0.0.9"};
  for (int i = 4; i < 200; ++i) {
    const std::string ip = fmt::format("10.0.1.{}", i % 250);
    const auto a = admit_connection(open, ip, 4, 2, protect);
    ASSERT_TRUE(a.admit);
    ASSERT_TRUE(a.evict);
    ASSERT_NE(open[*a.evict].ip, "10.0.0.9") << "evicted the protected client for " << ip;
    open.erase(open.begin() + static_cast<std::ptrdiff_t>(*a.evict));
    open.push_back({ip, now});
  }
  // Unprotected, the same flood takes its slot at once.
  open = {{"10.0.0.9", now - std::chrono::seconds(50)}, {"10.0.1.1", now}};
  const auto a = admit_connection(open, "10.0.2.1", 2, 2);
  ASSERT_TRUE(a.evict);
  EXPECT_EQ(open[*a.evict].ip, "10.0.0.9");
  // Only protected connections open: a newcomer is refused, nobody evicted.
  const auto b = admit_connection({{"10.0.0.9", now}}, "10.0.2.1", 2, 1, protect);
  const auto c = admit_connection({{"10.0.0.9", now}, {"10.0.0.8", now}}, "10.0.2.1", 2, 2,
                                  {"10.0.0.9", "10.0.0.8"});
  EXPECT_TRUE(b.admit);
  EXPECT_FALSE(c.admit);
  EXPECT_FALSE(c.evict);
}

TEST(EventBlock, ImplausibleDataAndImplausibleResultsRaiseTheirOwnBits) {
  auto flags_of = [](const brakefit::pipeline::EventResult& e) {
    const auto w = event_block(event_json(e, "test", nullptr).dump(), 1, true);
    for (const auto& [addr, v] : w.input)
      if (addr == reg("event.flags").address) return v;
    return std::uint16_t{0xFFFF};
  };
  auto e = make_event(1, 50);
  EXPECT_EQ(flags_of(e) & (kFlagImplausibleData | kFlagImplausibleResult), 0);
  e.event.flags = {"aborted", "implausible_data"};
  e.event.end_reason = "implausible_data";
  EXPECT_NE(flags_of(e) & kFlagImplausibleData, 0);
  EXPECT_EQ(end_reason_code("implausible_data"), 11);
  EXPECT_EQ(end_reason_code("max_length"), 10);
  auto f = make_event(2, 50);
  MethodResult lm;
  lm.method = Method::Lm;
  lm.params = {18.45, 0.3, 13560.0, -4.0};
  lm.implausible = implausible_curve(lm.params, 3800.0);
  f.results.push_back(lm);
  EXPECT_NE(flags_of(f) & kFlagImplausibleResult, 0);
  const auto doc = event_json(f, "test", nullptr);
  EXPECT_FALSE(doc["results"][0]["implausible"].empty());
}

TEST(EventBlock, TyreBasisFitsArePublishedWithTheirBit) {
  // With a bench measurement model the method blocks carry the tyre's fits, bit 9 says so, and
  // the bound and plausibility bits describe what is published.
  auto block = [](const brakefit::pipeline::EventResult& e) {
    const auto w = event_block(event_json(e, "test", nullptr).dump(), 1, true);
    const std::map<std::uint16_t, std::uint16_t> regs(w.input.begin(), w.input.end());
    const std::uint16_t b = reg("event.hybrid.C").address;
    return std::make_pair(regs.at(reg("event.flags").address),
                          unpack_f32_abcd(regs.at(b), regs.at(static_cast<std::uint16_t>(b + 1))));
  };
  auto e = make_event(1, 50);
  MethodResult raw;
  raw.method = Method::Hybrid;
  raw.params = {18.45, 0.3, 13560.0, -4.0};
  raw.at_bound = {"C"};
  raw.implausible = implausible_curve(raw.params, 3800.0);
  e.results = {raw};
  const auto [raw_flags, raw_c] = block(e);
  EXPECT_EQ(raw_flags & kFlagTyreBasis, 0);
  EXPECT_NE(raw_flags & kFlagAtBound, 0);
  EXPECT_FLOAT_EQ(raw_c, 0.3f);
  MethodResult tyre = raw;
  tyre.basis = Basis::Tyre;
  tyre.params = {15.3, 1.58, 3380.0, 0.1};
  tyre.at_bound.clear();
  tyre.implausible = implausible_curve(tyre.params, 3800.0);
  e.tyre_results = {tyre};
  const auto [flags, c] = block(e);
  EXPECT_NE(flags & kFlagTyreBasis, 0);
  EXPECT_EQ(flags & (kFlagAtBound | kFlagImplausibleResult), 0);
  EXPECT_FLOAT_EQ(c, 1.58f);
  const auto doc = event_json(e, "test", nullptr);
  EXPECT_EQ(doc["results"][0]["basis"], "instrument");
  EXPECT_EQ(doc["tyre_results"][0]["basis"], "tyre");
}
