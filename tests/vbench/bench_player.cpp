// The virtual bench's driver, run inside the QEMU guest (tests/vbench/guest.sh):
//
//   bench_player play LOG SIMDIR PTYLINK SCALE GOFILE
//     plays a recorded test onto a gpio-sim chip: the x4 count steps of the log's reference and
//     wheel encoder frames become quadrature edges on lines 0/1 (reference A/B) and 2/3 (wheel
//     A/B), written through SIMDIR/sim_gpioN/pull at the log's edge times stretched by SCALE; and
//     it is the Modbus RTU pressure transducer (slave 1, input register 0, 0.01 bar per count) on
//     a pseudo-terminal linked at PTYLINK, answering with the log's pressure at the same stretched
//     time. It serves pressure from the start and plays the edges once GOFILE exists.
//
//   bench_player edges CHIPDEV SIMDIR UAPI EDGES PERIOD_US DELAY_MS [V2_BUFFER]
//     edge-loss measurement of the project's own GPIO reader: a driver thread steps one encoder
//     (lines 0/1) forward EDGES times, one edge each PERIOD_US; the reader (the daemon's
//     EdgeSource for UAPI v1 = libgpiod 1.6 or v2 = the kernel's v2 uAPI, and its EncoderFramer)
//     sleeps DELAY_MS between reads. Prints one "EDGES ..." line: driven, events read, decoded
//     count, illegal transitions, lost edges reported.
//
// Everything it computes comes from the log or the arguments; it asserts nothing (the guest script
// and the host test compare its figures with the daemon's).
#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "core/can/layout.hpp"
#include "drivers/candump_file.hpp"
#include "drivers/gpio.hpp"
#include "tests/tools/rtu_crc.hpp"

namespace bf = brakefit;

namespace {

std::int64_t mono_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void sleep_until_ns(std::int64_t t_ns) {
  timespec ts{static_cast<time_t>(t_ns / 1'000'000'000), static_cast<long>(t_ns % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

/// The four sim_gpioN/pull files, kept open.
class SimLines {
 public:
  explicit SimLines(const std::string& dir) {
    for (int i = 0; i < 4; ++i) {
      const std::string p = fmt::format("{}/sim_gpio{}/pull", dir, i);
      fd_[static_cast<std::size_t>(i)] = ::open(p.c_str(), O_WRONLY | O_CLOEXEC);
      if (fd_[static_cast<std::size_t>(i)] < 0)
        throw std::runtime_error(fmt::format("{}: {}", p, std::strerror(errno)));
      set(static_cast<unsigned>(i), false);
    }
  }
  void set(unsigned line, bool high) {
    const char* v = high ? "pull-up" : "pull-down";
    if (::pwrite(fd_[line], v, std::strlen(v), 0) < 0)
      throw std::runtime_error(fmt::format("sim_gpio{}: {}", line, std::strerror(errno)));
    level_[line] = high;
  }
  void toggle(unsigned line) { set(line, !level_[line]); }

 private:
  std::array<int, 4> fd_{};
  std::array<bool, 4> level_{};
};

/// The forward quadrature sequence 00 -> 10 -> 11 -> 01 (A leads; QuadratureDecoder counts it
/// up): which line an x4 step toggles from each phase, forward and backward.
unsigned step_line(int phase, bool forward) {
  // phase 0: AB=00, 1: 10, 2: 11, 3: 01. Forward from 0 and 2 toggles A; from 1 and 3 toggles B.
  const int p = forward ? phase : (phase + 3) % 4;
  return (p % 2 == 0) ? 0u : 1u;
}

struct Edge {
  std::int64_t t_us;  ///< log time since the first frame
  unsigned enc;       ///< 0 reference, 1 wheel
  bool forward;
};

struct Pressure {
  std::int64_t t_us;
  std::uint16_t counts;
};

/// Edges of one encoder's frames: dcount steps spread evenly from the previous last-edge time to
/// this frame's last-edge time (so the last one falls where the log says). The sender's edge clock
/// is put on the frame clock by the offset that leaves every last edge at or before its frame
/// (the smallest frame-minus-edge time: taking it from the first frame alone put the wheel's edges
/// up to 0.3 ms late, and clamping them to their frame bunched them there).
void encoder_edges(const std::vector<std::pair<std::int64_t, bf::can::EncoderMsg>>& msgs,
                   unsigned enc, std::vector<Edge>& out) {
  if (msgs.empty()) return;
  std::vector<std::int64_t> edge_us(msgs.size());
  edge_us[0] = static_cast<std::int64_t>(msgs[0].second.edge_time_us);
  for (std::size_t i = 1; i < msgs.size(); ++i)
    edge_us[i] = edge_us[i - 1] + static_cast<std::int32_t>(msgs[i].second.edge_time_us -
                                                            msgs[i - 1].second.edge_time_us);
  std::int64_t offset_us = INT64_MAX;
  for (std::size_t i = 1; i < msgs.size(); ++i)
    if (msgs[i].second.count_x4_mod != msgs[i - 1].second.count_x4_mod)
      offset_us = std::min(offset_us, msgs[i].first - edge_us[i]);
  if (offset_us == INT64_MAX) return;  // the encoder never moved
  std::int64_t prev_edge = edge_us[0] + offset_us;
  std::uint32_t prev_count = msgs.front().second.count_x4_mod;
  for (std::size_t i = 1; i < msgs.size(); ++i) {
    const auto& m = msgs[i].second;
    auto d = static_cast<std::int32_t>((m.count_x4_mod - prev_count) & 0xFFFFFFu);
    if (d & 0x800000) d -= 0x1000000;
    if (d == 0) continue;
    const std::int64_t last = edge_us[i] + offset_us;
    const int n = std::abs(d);
    for (int j = 1; j <= n; ++j)
      out.push_back({prev_edge + (last - prev_edge) * j / n, enc, d > 0});
    prev_edge = last;
    prev_count = m.count_x4_mod;
  }
}

/// Modbus RTU slave 1 on a pty master: FC 04 (and 03) of register 0 -> the pressure now.
void serve_rtu(int master, const std::vector<Pressure>& pressure,
               std::atomic<std::int64_t>& play_t0, double scale, std::atomic<bool>& stop,
               std::atomic<std::uint64_t>& answered) {
  std::vector<std::uint8_t> buf;
  while (!stop) {
    pollfd p{master, POLLIN, 0};
    if (::poll(&p, 1, 50) <= 0) continue;
    std::uint8_t tmp[256];
    const ssize_t n = ::read(master, tmp, sizeof tmp);
    if (n <= 0) continue;
    buf.insert(buf.end(), tmp, tmp + n);
    while (buf.size() >= 8) {
      if (buf[0] != 1 || (buf[1] != 4 && buf[1] != 3) ||
          brakefit::test::rtu_crc16(buf.data(), 6) != (buf[6] | (buf[7] << 8))) {
        buf.erase(buf.begin());  // not a request to us: resynchronise byte by byte
        continue;
      }
      const unsigned addr = (buf[2] << 8) | buf[3], count = (buf[4] << 8) | buf[5];
      std::vector<std::uint8_t> r{1, buf[1]};
      if (addr != 0 || count != 1) {
        r[1] |= 0x80;
        r.push_back(2);  // illegal data address
      } else {
        const std::int64_t t0 = play_t0.load();
        const std::int64_t log_us =
            t0 == 0
                ? 0
                : static_cast<std::int64_t>(static_cast<double>(mono_ns() - t0) / 1000.0 / scale);
        auto it = std::upper_bound(pressure.begin(), pressure.end(), log_us,
                                   [](std::int64_t t, const Pressure& q) { return t < q.t_us; });
        const std::uint16_t v =
            it == pressure.begin() ? pressure.front().counts : std::prev(it)->counts;
        r.push_back(2);
        r.push_back(static_cast<std::uint8_t>(v >> 8));
        r.push_back(static_cast<std::uint8_t>(v & 0xFF));
      }
      const std::uint16_t c = brakefit::test::rtu_crc16(r.data(), r.size());
      r.push_back(static_cast<std::uint8_t>(c & 0xFF));
      r.push_back(static_cast<std::uint8_t>(c >> 8));
      if (::write(master, r.data(), r.size()) < 0) break;
      ++answered;
      buf.erase(buf.begin(), buf.begin() + 8);
    }
  }
}

int play(const std::string& log, const std::string& simdir, const std::string& ptylink,
         double scale, const std::string& gofile) {
  const auto text = bf::drivers::read_candump_file(log);
  std::vector<std::pair<std::int64_t, bf::can::EncoderMsg>> ref, wheel;
  std::vector<Pressure> pressure;
  const std::int64_t t_first = text.frames.front().t_us;
  for (const auto& f : text.frames) {
    const auto m = bf::can::decode(f.frame);
    if (!m) continue;
    if (const auto* e = std::get_if<bf::can::EncoderMsg>(&*m)) {
      (e->channel == bf::can::Channel::Wheel ? wheel : ref).emplace_back(f.t_us - t_first, *e);
    } else if (const auto* p = std::get_if<bf::can::PressureMsg>(&*m)) {
      pressure.push_back({f.t_us - t_first, static_cast<std::uint16_t>(std::lround(
                                                std::max(0.0, p->pressure_bar) / 0.01))});
    }
  }
  if (ref.empty() || wheel.empty() || pressure.empty()) {
    fmt::print(stderr, "{}: needs reference, wheel and pressure frames\n", log);
    return 2;
  }
  std::vector<Edge> edges;
  encoder_edges(ref, 0, edges);
  encoder_edges(wheel, 1, edges);
  std::stable_sort(edges.begin(), edges.end(),
                   [](const Edge& a, const Edge& b) { return a.t_us < b.t_us; });

  int master = -1, slave = -1;
  if (::openpty(&master, &slave, nullptr, nullptr, nullptr) != 0) {
    fmt::print(stderr, "openpty: {}\n", std::strerror(errno));
    return 2;
  }
  termios tio{};
  ::tcgetattr(slave, &tio);
  ::cfmakeraw(&tio);
  ::tcsetattr(slave, TCSANOW, &tio);
  std::filesystem::remove(ptylink);
  std::filesystem::create_symlink(::ttyname(slave), ptylink);
  std::atomic<std::int64_t> play_t0{0};
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> answered{0};
  std::thread rtu([&] { serve_rtu(master, pressure, play_t0, scale, stop, answered); });

  SimLines lines(simdir);
  while (!std::filesystem::exists(gofile))
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  std::array<int, 2> phase{0, 0};
  std::array<std::uint64_t, 4> driven{};
  std::int64_t worst_late_ns = 0, worst_at_us = 0;
  std::array<std::uint64_t, 3> late{};  // edges written more than 0.5, 2, 5 ms after their time
  std::vector<std::uint64_t> late_by_tenth(64, 0);  // edges > 1 ms late per 0.1 s of log time
  const std::int64_t t0 = mono_ns() + 50'000'000;
  play_t0 = t0;
  for (const Edge& e : edges) {
    const std::int64_t due =
        t0 + static_cast<std::int64_t>(static_cast<double>(e.t_us) * 1000.0 * scale);
    const std::int64_t now = mono_ns();
    if (due > now) {
      sleep_until_ns(due);
    } else {
      const std::int64_t l = now - due;
      late[0] += l > 500'000;
      late[1] += l > 2'000'000;
      late[2] += l > 5'000'000;
      if (l > 1'000'000)
        ++late_by_tenth[std::min<std::size_t>(63, static_cast<std::size_t>(e.t_us / 100'000))];
      if (l > worst_late_ns) {
        worst_late_ns = l;
        worst_at_us = e.t_us;
      }
    }
    const unsigned line = 2 * e.enc + step_line(phase[e.enc], e.forward);
    lines.toggle(line);
    ++driven[line];
    phase[e.enc] = (phase[e.enc] + (e.forward ? 1 : 3)) % 4;
  }
  // Hold the last pressure until the log's end has passed, then release the brake.
  const std::int64_t end =
      t0 + static_cast<std::int64_t>(static_cast<double>(pressure.back().t_us) * 1000.0 * scale);
  sleep_until_ns(std::max(end, mono_ns()) + 200'000'000);
  const double wall_s = static_cast<double>(mono_ns() - t0) * 1e-9;
  fmt::print(
      "PLAY edges={} ref={} wheel={} lines={},{},{},{} log_s={:.3f} scale={} wall_s={:.3f} "
      "rate_edges_per_s={:.0f} worst_late_ms={:.2f} worst_at_log_s={:.3f} late_0.5ms={} "
      "late_2ms={} "
      "late_5ms={} rtu_answers={}\n",
      edges.size(), driven[0] + driven[1], driven[2] + driven[3], driven[0], driven[1], driven[2],
      driven[3], static_cast<double>(edges.back().t_us) * 1e-6, scale, wall_s,
      static_cast<double>(edges.size()) / wall_s, static_cast<double>(worst_late_ns) * 1e-6,
      static_cast<double>(worst_at_us) * 1e-6, late[0], late[1], late[2], answered.load());
  fmt::print("LATE_1MS_PER_TENTH {}\n", fmt::join(late_by_tenth, " "));
  std::fflush(stdout);
  // Keep answering (pressure at its last value) until killed: the daemon may still poll.
  rtu.join();
  return 0;
}

int edges(const std::string& chip, const std::string& simdir, const std::string& uapi, int n,
          int period_us, int delay_ms, int buffer) {
  bf::drivers::GpioConfig g;
  g.event_buffer_size = buffer;
  g.chip = chip;
  g.uapi = uapi == "v1" ? bf::drivers::GpioConfig::Uapi::V1 : bf::drivers::GpioConfig::Uapi::V2;
  SimLines lines(simdir);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  auto src = bf::drivers::open_edge_source(g);
  bf::drivers::EncoderFramer framer(g);
  framer.seed(src->levels());
  std::atomic<bool> done{false};
  std::uint64_t events = 0;
  std::thread reader([&] {
    int idle = 0;
    while (idle < 5) {
      auto ev = src->wait(100);
      events += ev.size();
      framer.process(std::move(ev));
      if (done) ++idle;
      if (delay_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    }
  });
  const std::int64_t t0 = mono_ns() + 20'000'000;
  int phase = 0;
  std::uint64_t late_05 = 0;
  for (int i = 0; i < n; ++i) {
    const std::int64_t due = t0 + static_cast<std::int64_t>(i) * period_us * 1000;
    sleep_until_ns(due);
    late_05 += mono_ns() - due > 500'000;
    lines.toggle(step_line(phase, true));
    phase = (phase + 1) % 4;
  }
  const double wall_s = static_cast<double>(mono_ns() - t0) * 1e-9;
  done = true;
  reader.join();
  fmt::print(
      "EDGES uapi={} buffer={} driven={} period_us={} rate_edges_per_s={:.0f} delay_ms={} "
      "events={} counted={} illegal={} lost_reported={} late_0.5ms={}\n",
      uapi, uapi == "v1" ? 16 : buffer, n, period_us, n / wall_s, delay_ms, events,
      framer.ref().count_x4(), framer.ref().illegal_transitions(), src->lost_edges(), late_05);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::vector<std::string> a(argv + 1, argv + argc);
    if (a.size() == 6 && a[0] == "play") return play(a[1], a[2], a[3], std::stod(a[4]), a[5]);
    if ((a.size() == 7 || a.size() == 8) && a[0] == "edges")
      return edges(a[1], a[2], a[3], std::stoi(a[4]), std::stoi(a[5]), std::stoi(a[6]),
                   a.size() == 8 ? std::stoi(a[7]) : 1024);
    fmt::print(
        stderr,
        "usage: bench_player play LOG SIMDIR PTYLINK SCALE GOFILE\n"
        "       bench_player edges CHIPDEV SIMDIR v1|v2 EDGES PERIOD_US DELAY_MS [V2_BUFFER]\n");
    return 64;
  } catch (const std::exception& e) {
    fmt::print(stderr, "bench_player: {}\n", e.what());
    return 1;
  }
}
