// Driver tests without hardware: the GPIO path through an edge-event seam, the CAN read path
// through a socketpair, replay pacing and the candump recorder (the Modbus RTU driver:
// test_modbus_rtu.cpp).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <thread>

#include "core/can/layout.hpp"
#include "core/pipeline/events.hpp"
#include "core/pipeline/samples.hpp"
#include "drivers/candump_file.hpp"
#include "drivers/gpio.hpp"
#include "drivers/modbus_rtu.hpp"
#include "drivers/replay.hpp"
#include "drivers/socketcan.hpp"
#include "test_util.hpp"
#include "tests/tools/rtu_crc.hpp"

using namespace brakefit;
using namespace brakefit::drivers;

namespace {

/// Quadrature edges of one encoder turning at a constant rate, A leading (forward).
std::vector<EdgeEvent> quadrature_edges(unsigned line_a, std::int64_t t0_ns, double counts_per_s,
                                        int n_counts) {
  std::vector<EdgeEvent> out;
  bool a = false, b = false;
  for (int i = 0; i < n_counts; ++i) {
    const auto t = t0_ns + static_cast<std::int64_t>((i + 1) * 1e9 / counts_per_s);
    switch (i % 4) {
      case 0:
        a = true;
        out.push_back({line_a, a, t});
        break;
      case 1:
        b = true;
        out.push_back({line_a + 1, b, t});
        break;
      case 2:
        a = false;
        out.push_back({line_a, a, t});
        break;
      default:
        b = false;
        out.push_back({line_a + 1, b, t});
        break;
    }
  }
  return out;
}

}  // namespace

TEST(Quadrature, CountsForwardAndBackwardWithoutIllegalTransitions) {
  QuadratureDecoder d;
  d.seed(false, false);
  for (const auto& e : quadrature_edges(0, 0, 1000, 400)) d.edge(e.line == 1, e.rising, e.t_ns);
  EXPECT_EQ(d.count_x4(), 400);
  EXPECT_EQ(d.illegal_transitions(), 0u);
  // Backward: B leads.
  QuadratureDecoder r;
  r.seed(false, false);
  for (const auto& e : quadrature_edges(0, 0, 1000, 400)) r.edge(e.line == 0, e.rising, e.t_ns);
  EXPECT_EQ(r.count_x4(), -400);
  EXPECT_EQ(r.illegal_transitions(), 0u);
}

TEST(Quadrature, TableIsAntisymmetricAndFlagsDoubleChanges) {
  for (int from = 0; from < 4; ++from)
    for (int to = 0; to < 4; ++to) {
      const int f = QuadratureDecoder::kTable[static_cast<std::size_t>(from << 2 | to)];
      const int b = QuadratureDecoder::kTable[static_cast<std::size_t>(to << 2 | from)];
      if ((from ^ to) == 3)
        EXPECT_EQ(f, QuadratureDecoder::kIllegal);
      else
        EXPECT_EQ(f, -b) << from << "->" << to;
    }
}

TEST(Quadrature, BouncingEdgesCancelAndDroppedEdgesAreCounted) {
  QuadratureDecoder d;
  d.seed(false, false);
  d.edge(false, true, 1);   // A up: +1
  d.edge(false, false, 2);  // bounce down: -1
  d.edge(false, true, 3);   // and up again: +1
  EXPECT_EQ(d.count_x4(), 1);
  EXPECT_EQ(d.illegal_transitions(), 0u);
  // A dropped B-rise: the next B event (fall) does not change B's level -> illegal.
  d.edge(false, false, 4);  // A down (decoder sees 00 -> -1, wrong but legal)
  d.edge(true, false, 5);   // B down while the decoder has B low: an edge was lost
  EXPECT_EQ(d.illegal_transitions(), 1u);
}

namespace {

/// Scripted edge source: hands out events in batches, counts waits (blocking, not spinning).
class ScriptedEdges final : public EdgeSource {
 public:
  explicit ScriptedEdges(std::vector<std::vector<EdgeEvent>> batches)
      : batches_(std::move(batches)) {}
  std::array<bool, 4> levels() override { return {false, false, false, false}; }
  std::vector<EdgeEvent> wait(int timeout_ms) override {
    ++waits;
    {
      std::lock_guard lk(mu_);
      if (next_ < batches_.size()) return batches_[next_++];
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(timeout_ms));
    return {};
  }
  std::atomic<int> waits{0};

 private:
  std::mutex mu_;
  std::vector<std::vector<EdgeEvent>> batches_;
  std::size_t next_ = 0;
};

}  // namespace

TEST(GpioPath, FramedCountsGiveTheEncoderSpeedsAndSlip) {
  // Roller encoder (1000 ppr, r = 0.1 m) at 5 km/h; wheel (1000 ppr, r = 0.3 m) 10 % slower.
  const double v_ref = 5 / 3.6, v_wheel = 0.9 * v_ref;
  const double ref_cps = v_ref / (2 * M_PI * 0.1) * 4000,
               wheel_cps = v_wheel / (2 * M_PI * 0.3) * 4000;
  GpioConfig gc;
  EncoderFramer framer(gc);
  framer.seed({false, false, false, false});
  auto ref = quadrature_edges(kRefA, 0, ref_cps, static_cast<int>(ref_cps * 0.5));
  auto wheel = quadrature_edges(kWheelA, 0, wheel_cps, static_cast<int>(wheel_cps * 0.5));
  pipeline::Calibration cal;
  pipeline::SampleBuilder sb(cal);
  // A pressure frame so samples are complete.
  can::PressureMsg pm;
  pm.pressure_bar = 10;
  sb.feed({0, "gpio0", can::encode(pm)});
  std::size_t ir = 0, iw = 0;
  std::vector<pipeline::Sample> samples;
  for (std::int64_t t_ms = 1; t_ms <= 500; ++t_ms) {
    std::vector<EdgeEvent> batch;
    while (ir < ref.size() && ref[ir].t_ns <= t_ms * 1'000'000) batch.push_back(ref[ir++]);
    while (iw < wheel.size() && wheel[iw].t_ns <= t_ms * 1'000'000) batch.push_back(wheel[iw++]);
    framer.process(batch);
    for (const auto& f : framer.frames(t_ms * 1000))
      if (auto s = sb.feed(f)) samples.push_back(*s);
  }
  ASSERT_GT(samples.size(), 400u);
  const auto& s = samples[450];
  EXPECT_NEAR(s.v_ref_mps, v_ref, 0.01 * v_ref);
  EXPECT_NEAR(s.v_wheel_mps, v_wheel, 0.01 * v_wheel);
  EXPECT_NEAR(1 - s.v_wheel_mps / s.v_ref_mps, 0.1, 0.01);
  EXPECT_EQ(framer.ref().illegal_transitions() + framer.wheel().illegal_transitions(), 0u);
}

TEST(GpioPath, ReaderThreadBlocksInTheSourceAndCountsDroppedEdges) {
  auto batch = quadrature_edges(kRefA, 1'000'000, 100'000, 400);
  batch.erase(batch.begin() + 101);  // the kernel FIFO dropped an edge
  auto bounce = std::vector<EdgeEvent>{
      {kWheelA, true, 2'000'000}, {kWheelA, false, 2'000'100}, {kWheelA, true, 2'000'200}};
  auto src = std::make_unique<ScriptedEdges>(std::vector<std::vector<EdgeEvent>>{batch, bounce});
  auto* raw = src.get();
  FrameQueue q;
  DriverCounters counters;
  LiveClock clock;
  GpioConfig gc;
  gc.frame_period_ms = 5;
  int waits = 0;
  {
    GpioEncoderReader reader(gc, std::move(src), q, counters, clock);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    waits = raw->waits.load();  // the reader owns the source: read before it goes
  }
  EXPECT_GE(counters.illegal_transitions.load(), 1u);
  // 200 ms at a 5 ms frame period: about 40 waits, each blocking (no busy loop).
  EXPECT_LT(waits, 100);
  EXPECT_GT(waits, 10);
  EXPECT_GE(counters.frames.load(), 2u * 20u);
  std::optional<can::LoggedFrame> last_ref, last_wheel;
  std::optional<can::EncoderFaultsMsg> faults;
  while (auto f = q.pop(0)) {
    if (f->frame.id == can::kIdEncoderFaults)
      faults = std::get<can::EncoderFaultsMsg>(*can::decode(f->frame));
    else
      (f->frame.id == can::kIdWheelEncoder ? last_wheel : last_ref) = *f;
  }
  // The loss rides in the stream too (recorded, replayed): an ENCODER_FAULTS frame with it.
  ASSERT_TRUE(faults);
  EXPECT_GE(faults->illegal_transitions_mod, 1u);
  ASSERT_TRUE(last_ref && last_wheel);
  const auto r = std::get<can::EncoderMsg>(*can::decode(last_ref->frame));
  const auto w = std::get<can::EncoderMsg>(*can::decode(last_wheel->frame));
  EXPECT_NE(r.count_x4_mod, 0u);
  EXPECT_EQ(w.count_x4_mod, 1u);  // bounce: up, down, up = one count
}

TEST(SocketCan, ReadsRecordsWithTheirBoundariesAndTimestampsThroughASocketpair) {
  int sv[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
  CanSocket sock(sv[0], "can0");
  DriverCounters counters;
  can::PressureMsg pm;
  pm.pressure_bar = 42.5;
  pm.counter = 7;
  const can::Frame f = can::encode(pm);
  auto rec = record_from_frame(f);
  ASSERT_EQ(rec.size(), 16u);
  ASSERT_EQ(::send(sv[1], rec.data(), rec.size(), 0), 16);
  ASSERT_EQ(::send(sv[1], rec.data(), 5, 0), 5);  // a truncated record
  const auto before_us = std::chrono::duration_cast<std::chrono::microseconds>(
                             std::chrono::system_clock::now().time_since_epoch())
                             .count();
  auto got = sock.read(100, &counters);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->frame.id, can::kIdBrakePressure);
  EXPECT_EQ(got->frame.len, f.len);
  EXPECT_EQ(std::memcmp(got->frame.data.data(), f.data.data(), f.len), 0);
  EXPECT_NEAR(static_cast<double>(got->t_us), static_cast<double>(before_us), 2e6);
  const auto dec = std::get<can::PressureMsg>(*can::decode(got->frame));
  EXPECT_NEAR(dec.pressure_bar, 42.5, 0.01);
  EXPECT_FALSE(sock.read(100, &counters));  // the 5-byte record is refused and counted
  EXPECT_EQ(counters.can_errors.load(), 1u);
  EXPECT_FALSE(sock.read(20, &counters));  // nothing more: timeout
  ::close(sv[1]);
}

TEST(SocketCan, ParsesExtendedRemoteAndFdRecords) {
  can::Frame f;
  f.id = 0x12345678;
  f.extended = true;
  f.remote = true;
  f.len = 4;
  auto rec = record_from_frame(f);
  auto back = frame_from_record(rec.data(), rec.size());
  ASSERT_TRUE(back);
  EXPECT_EQ(back->id, 0x12345678u);
  EXPECT_TRUE(back->extended);
  EXPECT_TRUE(back->remote);
  std::vector<std::uint8_t> fd(72, 0);
  fd[0] = 0x23;
  fd[4] = 12;
  fd[5] = 0x1;  // BRS
  fd[8] = 0xAB;
  auto fdf = frame_from_record(fd.data(), fd.size());
  ASSERT_TRUE(fdf);
  EXPECT_TRUE(fdf->fd);
  EXPECT_EQ(fdf->len, 12);
  EXPECT_EQ(fdf->data[0], 0xAB);
  EXPECT_FALSE(frame_from_record(fd.data(), 20));
}

TEST(SocketCan, AbsentInterfaceOrKernelSupportIsNamed) {
  try {
    CanSocket::open("brakefitcan9", {0x100});
    FAIL() << "opened a CAN interface that does not exist";
  } catch (const SourceError& e) {
    EXPECT_NE(std::string(e.what()).find("brakefitcan9"), std::string::npos) << e.what();
  }
}

TEST(Gpio, AbsentChipIsNamed) {
  GpioConfig g;
  g.chip = "gpiochip99";
  for (auto uapi : {GpioConfig::Uapi::V1, GpioConfig::Uapi::V2}) {
    g.uapi = uapi;
    try {
      open_edge_source(g);
      FAIL();
    } catch (const SourceError& e) {
      EXPECT_NE(std::string(e.what()).find("gpiochip99"), std::string::npos);
    }
  }
}

TEST(GpioPath, LostEdgesDuringAnEventFlagItAndItIsStillFitted) {
  // The framer reports its totals when they change; the sample builder turns the growth into a
  // running count; the detector flags the event during which it grew.
  GpioConfig gc;
  EncoderFramer framer(gc);
  framer.seed({false, false, false, false});
  auto first = framer.faults_frame(0, 0);
  ASSERT_TRUE(first);                       // the first report always goes out
  EXPECT_FALSE(framer.faults_frame(0, 1));  // nothing changed: nothing sent
  auto grown = framer.faults_frame(7, 2);   // seven edges the kernel dropped
  ASSERT_TRUE(grown);
  pipeline::Calibration cal;
  pipeline::SampleBuilder sb(cal);
  sb.feed(*first);
  sb.feed(*grown);
  EXPECT_EQ(sb.stats().encoder_faults, 7u);
  pipeline::EventSettings es;
  pipeline::EventDetector det(cal, es);
  std::optional<pipeline::Event> ev;
  for (int i = 0; i < 200 && !ev; ++i) {
    pipeline::Sample s;
    s.t_ns = i * 1'000'000;
    s.v_ref_mps = 1.39;
    s.v_wheel_mps = 1.39 * (1 - 0.001 * i);
    s.pressure_bar = i < 150 ? 5.0 : 0.0;
    s.encoder_faults = i < 60 ? 0 : 7;  // lost in the middle of the event
    ev = det.feed(s);
  }
  ASSERT_TRUE(ev);
  EXPECT_NE(std::find(ev->flags.begin(), ev->flags.end(), "edges_lost"), ev->flags.end());
  EXPECT_TRUE(ev->fittable());
}

TEST(Replay, FastReplayDeliversEveryFrameAndPacedReplayKeepsTime) {
  const std::string log = test::source_path("tests/fixtures/candump_L.log");
  const auto all = read_candump_file(log).frames;
  ReplaySource fast(log, 0);
  std::size_t n = 0;
  while (!fast.finished())
    if (fast.next(10)) ++n;
  EXPECT_EQ(n, all.size());
  const double span_s = static_cast<double>(all.back().t_us - all.front().t_us) * 1e-6;
  ASSERT_GT(span_s, 0.0);
  const double speed = span_s / 0.2;  // the whole log in 0.2 s
  ReplaySource paced(log, speed);
  const auto t0 = std::chrono::steady_clock::now();
  n = 0;
  while (!paced.finished())
    if (paced.next(10)) ++n;
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(n, all.size());
  EXPECT_GE(took, 0.18);
  EXPECT_LT(took, 2.0);
}

TEST(Recorder, RotatesBySizeKeepsTheNewestAndReplaysExactly) {
  const auto dir =
      std::filesystem::temp_directory_path() / ("bf_rec_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::vector<can::LoggedFrame> frames;
  for (int i = 0; i < 300; ++i) {
    can::PressureMsg pm;
    pm.pressure_bar = i * 0.1;
    pm.counter = static_cast<std::uint8_t>(i);
    frames.push_back({1'700'000'000'000'000 + i * 1000, "rtu0", can::encode(pm)});
  }
  {
    CandumpRecorder rec(dir.string(), 4000, 3600, 3);
    for (const auto& f : frames) ASSERT_TRUE(rec.write(f));
    EXPECT_GE(rec.rotations(), 3u);
  }
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir)) files.push_back(e.path());
  EXPECT_EQ(files.size(), 3u);  // keep_files
  std::sort(files.begin(), files.end());
  std::vector<can::LoggedFrame> back;
  for (const auto& f : files)
    for (const auto& fr : read_candump_file(f.string()).frames) back.push_back(fr);
  ASSERT_FALSE(back.empty());
  // The kept files hold the newest frames, unchanged and in order.
  const std::size_t off = frames.size() - back.size();
  for (std::size_t i = 0; i < back.size(); ++i) {
    EXPECT_EQ(back[i].t_us, frames[off + i].t_us);
    EXPECT_EQ(back[i].frame.data, frames[off + i].frame.data);
  }
  std::filesystem::remove_all(dir);
}
