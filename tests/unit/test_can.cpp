#include <gtest/gtest.h>

#include "tests/unit/test_util.hpp"

#include "core/can/candump.hpp"
#include "core/can/layout.hpp"
#include "core/curve.hpp"
#include "core/pipeline/samples.hpp"

using namespace brakefit;
using namespace brakefit::can;

TEST(Dbc, CompiledLayoutMatchesConfigDbcFile) {
  const std::string path = brakefit::test::source_path("config/brakefit.dbc");
  const auto dbc = parse_dbc(brakefit::test::read_text(path), path);
  ASSERT_EQ(dbc.size(), layout().size());
  for (const MessageDef& m : layout()) {
    const auto it =
        std::find_if(dbc.begin(), dbc.end(), [&](const MessageDef& d) { return d.id == m.id; });
    ASSERT_NE(it, dbc.end()) << m.name;
    EXPECT_EQ(it->name, m.name);
    EXPECT_EQ(it->dlc, m.dlc);
    ASSERT_EQ(it->signals.size(), m.signals.size()) << m.name;
    for (std::size_t i = 0; i < m.signals.size(); ++i) {
      const SignalDef &a = it->signals[i], &b = m.signals[i];
      EXPECT_EQ(a.name, b.name);
      EXPECT_EQ(a.start_bit, b.start_bit) << m.name << "." << b.name;
      EXPECT_EQ(a.length, b.length) << m.name << "." << b.name;
      EXPECT_EQ(a.is_signed, b.is_signed) << m.name << "." << b.name;
      EXPECT_DOUBLE_EQ(a.scale, b.scale) << m.name << "." << b.name;
      EXPECT_DOUBLE_EQ(a.offset, b.offset);
      EXPECT_DOUBLE_EQ(a.min, b.min) << m.name << "." << b.name;
      EXPECT_DOUBLE_EQ(a.max, b.max) << m.name << "." << b.name;
      EXPECT_EQ(a.unit, b.unit) << m.name << "." << b.name;
    }
  }
}

TEST(Dbc, MalformedOrUnsupportedLinesNameTheLine) {
  EXPECT_THROW(parse_dbc("BO_ 1 A: 8 X\n SG_ s : 0|8@0+ (1,0) [0|1] \"\" X\n", "x.dbc"),
               InputError);
  try {
    parse_dbc("BO_ 1 A: 8 X\n SG_ s : 60|8@1+ (1,0) [0|1] \"\" X\n", "x.dbc");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("x.dbc:2: signal s does not fit", 0), 0u);
  }
}

TEST(Codec, RoundTripsEveryMessageAtItsResolution) {
  EncoderMsg e{Channel::FifthWheel, 0xABCDEF, 4000000000u, 200};
  const auto de = std::get<EncoderMsg>(*decode(encode(e)));
  EXPECT_EQ(de.channel, Channel::FifthWheel);
  EXPECT_EQ(de.count_x4_mod, 0xABCDEFu);
  EXPECT_EQ(de.edge_time_us, 4000000000u);
  EXPECT_EQ(de.counter, 200);
  PressureMsg p{123.456, 1, 7, 99};
  const auto dp = std::get<PressureMsg>(*decode(encode(p)));
  EXPECT_NEAR(dp.pressure_bar, 123.46, 1e-9);
  EXPECT_EQ(dp.status, 1);
  TesterForceMsg f{-4321.26, 3, 5};
  EXPECT_NEAR(std::get<TesterForceMsg>(*decode(encode(f))).brake_force_n, -4321.3, 1e-6);
  TestStateMsg s{TestState::SwitchedOff, BenchKind::Ground, 9, 40.0, 1};
  const auto ds = std::get<TestStateMsg>(*decode(encode(s)));
  EXPECT_EQ(ds.state, TestState::SwitchedOff);
  EXPECT_EQ(ds.bench, BenchKind::Ground);
  EXPECT_NEAR(ds.set_speed_kmh, 40.0, 1e-9);
  EncoderFaultsMsg ef{0x1000005, 17, 3};  // totals wrap modulo 2^24
  const auto def = std::get<EncoderFaultsMsg>(*decode(encode(ef)));
  EXPECT_EQ(def.lost_edges_mod, 5u);
  EXPECT_EQ(def.illegal_transitions_mod, 17u);
  EXPECT_EQ(def.counter, 3);
  // Out-of-range values clamp to the signal's range instead of wrapping.
  PressureMsg big{1e6, 0, 0, 0};
  EXPECT_NEAR(std::get<PressureMsg>(*decode(encode(big))).pressure_bar, 655.35, 1e-9);
  // Unknown ids and remote frames are not decoded.
  Frame unknown;
  unknown.id = 0x555;
  EXPECT_FALSE(decode(unknown));
  Frame remote = encode(p);
  remote.remote = true;
  EXPECT_FALSE(decode(remote));
}

TEST(Candump, FormatsLikeCandumpAndParsesBack) {
  LoggedFrame f{1700000000123456, "can0", encode(PressureMsg{10.0, 0, 1, 2})};
  const std::string line = format_candump_line(f);
  EXPECT_EQ(line, "(1700000000.123456) can0 110#E803000102000000");
  const auto back = parse_candump_line(line);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->t_us, f.t_us);
  EXPECT_EQ(format_frame_text(back->frame), "110#E803000102000000");
  Frame ext;
  ext.id = 0x1ABCDEF0;
  ext.extended = true;
  ext.len = 2;
  ext.data[0] = 0x0A;
  ext.data[1] = 0xFF;
  EXPECT_EQ(format_frame_text(ext), "1ABCDEF0#0AFF");
  Frame rtr;
  rtr.id = 0x12;
  rtr.remote = true;
  rtr.len = 3;
  EXPECT_EQ(format_frame_text(rtr), "012#R3");
}

TEST(Candump, ATextLineAmongTheFramesIsAnErrorNamingItsLineOrCountedWhenLenient) {
  const std::string text =
      "(1700000000.000100) can0 100#0800008903000000\n"
      "operator note: second run\n"
      "(1700000000.000200) can0 101#020000A702000000\n";
  try {
    parse_candump_text(text, "x.log", false);
    FAIL() << "a text line was taken silently";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("x.log:2: not a candump line"), std::string::npos)
        << e.what();
  }
  const CandumpText t = parse_candump_text(text, "x.log", true);
  EXPECT_EQ(t.frames.size(), 2u);
  EXPECT_EQ(t.malformed, 1u);
  EXPECT_EQ(t.ignored, 0u);
}

TEST(Candump, ReplaysTheCommittedCandumpLFixture) {
  const std::string path = brakefit::test::source_path("tests/fixtures/candump_L.log");
  const CandumpText t = parse_candump_text(brakefit::test::read_text(path), path, false);
  EXPECT_EQ(t.frames.size(), 10u);
  EXPECT_EQ(t.ignored, 3u);  // two comments, a blank line
  EXPECT_TRUE(t.frames[1].frame.extended);
  EXPECT_EQ(t.frames[1].frame.id, 0x12345678u);
  EXPECT_TRUE(t.frames[3].frame.remote);
  EXPECT_EQ(t.frames[3].iface, "can1");
  EXPECT_EQ(t.frames[4].frame.len, 5);
  EXPECT_EQ(t.frames[6].frame.len, 3);  // dot-separated data
  EXPECT_TRUE(t.frames[7].frame.fd);
  EXPECT_EQ(t.frames[7].frame.fd_flags, 1);
  EXPECT_EQ(t.frames[7].frame.len, 8);
  EXPECT_EQ(t.frames[8].frame.len, 0);
  // Every frame prints back to its text.
  EXPECT_EQ(format_candump_line(t.frames[7]), "(1700000000.000450) can0 456##1AABBCCDDEEFF0011");
  // The decodable frames decode; the rest are not in the layout.
  std::size_t known = 0;
  for (const auto& f : t.frames) known += decode(f.frame).has_value();
  EXPECT_EQ(known, 4u);
  // The replay pipeline counts and ignores the frames it does not know.
  pipeline::SampleBuilder sb(pipeline::Calibration{});
  for (const auto& f : t.frames) sb.feed(f);
  EXPECT_EQ(sb.stats().frames, 10u);
  EXPECT_EQ(sb.stats().unknown_ids, 6u);
}

TEST(Candump, MalformedLinesGiveTheLineNumberOrAreCountedWhenLenient) {
  const std::string text =
      "(1700000000.000100) can0 100#00\n(1700000000.0001) can0 100#00\n(1700000000.000300) can0 "
      "1000#00\n"
      "(1700000000.000400) can0 100#0\n(1700000000.000500) can0 100#0011223344556677889\n"
      "(1700000000.000600) can0 1G0#00\n(1700000000.000700) can0\n";
  try {
    parse_candump_text(text, "bad.log", false);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("bad.log:2: timestamp", 0), 0u) << e.what();
  }
  const CandumpText t = parse_candump_text(text, "bad.log", true);
  EXPECT_EQ(t.frames.size(), 1u);
  EXPECT_EQ(t.malformed, 6u);
}

// Found by fuzzing and a hostile operator (issue 12): each is a clear error, never UB.
TEST(Candump, StampsThatOverflowOrAreNegativeAreErrors) {
  for (const char* line : {"(17000000000000000.007000) can0 100#00", "(-1.000000) can0 100#00",
                           "(1.-00001) can0 100#00", "(99999999999999999999.000000) can0 100#00"}) {
    try {
      parse_candump_text(std::string(line) + "\n", "s.log", false);
      ADD_FAILURE() << line;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("s.log:1: timestamp", 0), 0u) << e.what();
    }
  }
  // Stamps up to 9e9 s (nanoseconds still fit 64 bits in the pipeline) are read exactly.
  const auto t = parse_candump_text("(9000000000.000001) can0 100#00\n", "s.log", false);
  EXPECT_EQ(t.frames.at(0).t_us, 9000000000000001LL);
  EXPECT_THROW(parse_candump_text("(9000000001.000000) can0 100#00\n", "s.log", false), InputError);
}

TEST(Dbc, SixtyFourBitSignalsEncodeTheirExtremesWithoutOverflow) {
  for (bool is_signed : {false, true}) {
    SignalDef s;
    s.start_bit = 0;
    s.length = 64;
    s.is_signed = is_signed;
    Frame f;
    f.len = 8;
    encode_signal(f, s, 1e30);  // clamped to the largest raw value
    EXPECT_EQ(f.data[6], 0xFF);
    EXPECT_EQ(f.data[7], is_signed ? 0x7F : 0xFF);
    encode_signal(f, s, -1e30);
    EXPECT_EQ(f.data[7], is_signed ? 0x80 : 0x00);
    encode_signal(f, s, std::nan(""));
    EXPECT_EQ(f.data[7], 0x00);
  }
  // Signed decoding of every length up to 64 bits (63 and 64 once overflowed).
  for (unsigned len : {8u, 63u, 64u}) {
    SignalDef s;
    s.length = len;
    s.is_signed = true;
    Frame f;
    f.len = 8;
    f.data.fill(0xFF);
    EXPECT_EQ(decode_signal(f, s), -1.0) << len;
    encode_signal(f, s, -std::ldexp(1.0, static_cast<int>(len) - 1));
    EXPECT_EQ(decode_signal(f, s), -std::ldexp(1.0, static_cast<int>(len) - 1)) << len;
  }
}

TEST(Dbc, OutOfRangeNumbersAndHugeLinesAreErrorsNamingTheLine) {
  const std::string bo = "BO_ 1 A: 8 X\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {bo + " SG_ s : 4294967295|8@1+ (1,0) [0|1] \"\" X\n", "x.dbc:2: the start bit must be"},
      {"BO_ 1 A: 100 X\n", "x.dbc:1: the DLC must be 0..64"},
      {"BO_ 99999999999999999999 A: 8 X\n", "x.dbc:1: the message id must be"},
      {bo + " SG_ s : 0|0@1+ (1,0) [0|1] \"\" X\n", "x.dbc:2: the length must be 1..64"},
      {bo + " SG_ s : 0|8@1+ (1e999,0) [0|1] \"\" X\n", "x.dbc:2: expected the scale"},
      {bo + " SG_ s : 0|8@1+ (0,0) [0|1] \"\" X\n", "x.dbc:2: the scale must not be 0"},
      {bo + " SG_ s : 0|8@1+ (1,0) [0|1] \"unterminated\n", "x.dbc:2: the unit has no closing"},
      {bo + " SG_ s : 0|8@1+ (1,0) [0|1] \"" + std::string(300000, 'u') + " X\n",
       "x.dbc:2: the unit has no closing"},
      {bo + " SG_ " + std::string(300000, 's') + " : 0|8@1+ (1,0) [0|1] \"\" X\n", ""},
  };
  for (const auto& [text, want] : cases) {
    try {
      const auto m = parse_dbc(text, "x.dbc");
      EXPECT_EQ(want, "") << text.substr(0, 80);  // only the long name is valid
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(want, 0), 0u) << e.what();
    }
  }
}

namespace {

/// An encoder's frames one after another: counts and edge clock advanced by each step.
struct EncoderFrames {
  EncoderFrames(double radius_m, Channel ch, std::uint32_t edge_us)
      : sp(1000, radius_m), m_per_count(2.0 * M_PI * radius_m / 4000.0), m{ch, 0, edge_us, 0} {}
  double step(std::uint32_t counts, std::uint32_t dt_us) {
    m.count_x4_mod = (m.count_x4_mod + counts) & 0xFFFFFFu;
    m.edge_time_us += dt_us;
    t_ns += dt_us * 1000LL;
    return sp.update(m, t_ns);
  }
  brakefit::pipeline::EncoderSpeed sp;
  double m_per_count;
  EncoderMsg m;
  std::int64_t t_ns = 0;
};

}  // namespace

// A bench controller that restarts its edge clock (or a log joined to itself): the speed comes
// back at once instead of reading 0 until the clock catches up (up to 71 minutes).
TEST(EncoderSpeed, AnEdgeClockThatGoesBackIsAResyncNotAnHourOfZeroSpeed) {
  EncoderFrames e(0.1, Channel::Roller, 5'000'000);
  for (int i = 0; i < 10; ++i) e.step(14, 1000);
  EXPECT_NEAR(e.sp.speed_mps(), 14 * e.m_per_count / 1e-3, 1e-9);
  e.m.edge_time_us = 100;  // the clock restarts; counts jump too
  e.m.count_x4_mod = 77;
  e.t_ns += 1'000'000;
  e.sp.update(e.m, e.t_ns);
  EXPECT_EQ(e.sp.resyncs(), 1u);
  EXPECT_NEAR(e.step(7, 1000), 7 * e.m_per_count / 1e-3, 1e-9);  // the next frame has the speed
}

TEST(EncoderSpeed, EdgesCloserThanAFrameCanResolveHoldTheSpeedUntilTheNextFrame) {
  // The daemon once read 183 m/s: a frame 2.6 us after the one before, one count between them.
  EncoderFrames e(0.3, Channel::Wheel, 1'000'000);
  for (int i = 0; i < 5; ++i) e.step(3, 1000);
  EXPECT_NEAR(e.step(1, 3), 3 * e.m_per_count / 1e-3, 1e-9);  // held, not 1 count / 3 us
  EXPECT_EQ(e.sp.short_spans(), 1u);
  EXPECT_NEAR(e.step(3, 997), 4 * e.m_per_count / 1e-3, 1e-9);  // the next frame spans both
}

TEST(EncoderSpeed, AWheelThatStopsRightAfterAShortSpanReadsZeroNotTheHeldSpeed) {
  // A ground run's wheel locked just after two edges 60 us apart: the held 6 m/s stayed for
  // ever, the slip read -20 and the lock was never detected (the event ended aborted).
  EncoderFrames e(0.3, Channel::Wheel, 1'000'000);
  for (int i = 0; i < 5; ++i) e.step(13, 1000);
  const double held = e.step(1, 60);  // the last edge, 60 us after the one before
  EXPECT_NEAR(held, 13 * e.m_per_count / 1e-3, 1e-9);
  EXPECT_EQ(e.sp.short_spans(), 1u);
  double v = held;
  for (int i = 1; i <= 250; ++i) {  // frames every 1 ms, no edge any more
    e.t_ns += 1'000'000;
    v = e.sp.update(e.m, e.t_ns);
    EXPECT_LE(v, e.m_per_count / (i * 1e-3) + 1e-12) << i;  // at most one count over the wait
  }
  EXPECT_EQ(v, 0.0);  // stopped: 0.2 s without an edge
  EXPECT_EQ(e.sp.short_spans(), 1u);
}
