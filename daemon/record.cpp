// One finished event as the store keeps it: its row's fields and its raw samples packed in a
// BLOB, and the same record as CBOR (the spill file format, read back with a clear error).
#include "daemon/record.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cstring>
#include <random>

#include <nlohmann/json.hpp>

#include "core/curve.hpp"

namespace brakefit::daemon {

namespace {

constexpr std::size_t kRecord = 8 + 4 * 8 + 2;

template <typename T>
void put(std::string& out, T v) {
  char b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  out.append(b, sizeof v);
}
template <typename T>
T get(const unsigned char*& p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  p += sizeof v;
  return v;
}

/// Counts nesting only: a spill record is an object of scalars and one byte string (depth 1), so
/// anything deeper is refused before nlohmann's recursive reader could exhaust the stack on it.
struct DepthCheck : nlohmann::json::json_sax_t {
  static constexpr int kMaxDepth = 8;
  int depth = 0;
  bool too_deep = false;
  bool open() {
    if (++depth <= kMaxDepth) return true;
    too_deep = true;
    return false;
  }
  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(number_integer_t) override { return true; }
  bool number_unsigned(number_unsigned_t) override { return true; }
  bool number_float(number_float_t, const string_t&) override { return true; }
  bool string(string_t&) override { return true; }
  bool binary(binary_t&) override { return true; }
  bool start_object(std::size_t) override { return open(); }
  bool key(string_t&) override { return true; }
  bool end_object() override { return --depth, true; }
  bool start_array(std::size_t) override { return open(); }
  bool end_array() override { return --depth, true; }
  bool parse_error(std::size_t, const std::string&, const nlohmann::json::exception&) override {
    return false;
  }
};

}  // namespace

std::string pack_samples(const std::vector<pipeline::Sample>& s) {
  std::string out;
  out.reserve(s.size() * kRecord);
  for (const auto& x : s) {
    put(out, x.t_ns);
    put(out, x.v_ref_mps);
    put(out, x.v_wheel_mps);
    put(out, x.pressure_bar);
    put(out, x.force_n);
    put(out, static_cast<std::uint8_t>(x.state));
    put(out, static_cast<std::uint8_t>(x.sensor_fault ? 1 : 0));
  }
  return out;
}

std::vector<pipeline::Sample> unpack_samples(const void* data, std::size_t n) {
  std::vector<pipeline::Sample> out;
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i + kRecord <= n; i += kRecord) {
    pipeline::Sample s;
    s.t_ns = get<std::int64_t>(p);
    s.v_ref_mps = get<double>(p);
    s.v_wheel_mps = get<double>(p);
    s.pressure_bar = get<double>(p);
    s.force_n = get<double>(p);
    s.state = static_cast<can::TestState>(get<std::uint8_t>(p));
    s.sensor_fault = get<std::uint8_t>(p) != 0;
    out.push_back(s);
  }
  return out;
}

EventRecord make_record(const pipeline::EventResult& e, const std::string& result_json,
                        const std::string& calibration_toml, const std::string& vehicle_id,
                        const std::string& source, const std::string& model_hash,
                        std::int64_t now_unix_s) {
  EventRecord r;
  std::random_device rd;
  r.uid = fmt::format("{:08x}{:08x}{:08x}{:08x}", rd(), rd(), rd(), rd());
  r.created_unix_s = now_unix_s;
  r.source = source;
  r.vehicle_id = vehicle_id;
  r.bench = can::to_string(e.event.bench);
  r.end_reason = e.event.end_reason;
  r.flags = fmt::format("{}", fmt::join(e.event.flags, ","));
  r.model_hash = model_hash;
  r.pipeline_event_id = e.event.event_id;
  r.t_start_ns = e.event.t_start_ns;
  r.t_end_ns = e.event.t_end_ns;
  r.points = static_cast<std::int64_t>(e.curve.size());
  r.calibration_toml = calibration_toml;
  r.result_json = result_json;
  r.sample_count = static_cast<std::int64_t>(e.event.samples.size());
  r.samples_blob = pack_samples(e.event.samples);
  return r;
}

pipeline::Event event_from_record(const EventRecord& r) {
  pipeline::Event e;
  e.event_id = static_cast<int>(r.pipeline_event_id);
  e.bench = r.bench == can::to_string(can::BenchKind::Ground) ? can::BenchKind::Ground
                                                              : can::BenchKind::Roller;
  e.t_start_ns = r.t_start_ns;
  e.t_end_ns = r.t_end_ns;
  e.end_reason = r.end_reason;
  for (std::size_t a = 0; a < r.flags.size();) {
    const auto b = std::min(r.flags.find(',', a), r.flags.size());
    if (b > a) e.flags.push_back(r.flags.substr(a, b - a));
    a = b + 1;
  }
  e.samples = unpack_samples(r.samples_blob.data(), r.samples_blob.size());
  return e;
}

std::string record_to_cbor(const EventRecord& r) {
  nlohmann::json j;
  j["schema"] = "brakefit.spilled_event/1";
  j["uid"] = r.uid;
  j["created_unix_s"] = r.created_unix_s;
  j["source"] = r.source;
  j["vehicle_id"] = r.vehicle_id;
  j["bench"] = r.bench;
  j["end_reason"] = r.end_reason;
  j["flags"] = r.flags;
  j["model_hash"] = r.model_hash;
  j["pipeline_event_id"] = r.pipeline_event_id;
  j["t_start_ns"] = r.t_start_ns;
  j["t_end_ns"] = r.t_end_ns;
  j["points"] = r.points;
  j["calibration_toml"] = r.calibration_toml;
  j["result_json"] = r.result_json;
  j["sample_count"] = r.sample_count;
  j["samples"] = nlohmann::json::binary(
      std::vector<std::uint8_t>(r.samples_blob.begin(), r.samples_blob.end()));
  const auto bytes = nlohmann::json::to_cbor(j);
  return {bytes.begin(), bytes.end()};
}

EventRecord record_from_cbor(std::string_view bytes, const std::string& where) {
  nlohmann::json j;
  DepthCheck depth;
  if (!nlohmann::json::sax_parse(bytes.begin(), bytes.end(), &depth,
                                 nlohmann::json::input_format_t::cbor, false) &&
      depth.too_deep)
    throw InputError(fmt::format("{}: not a spilled event: nested deeper than {} levels", where,
                                 DepthCheck::kMaxDepth));
  try {
    j = nlohmann::json::from_cbor(bytes.begin(), bytes.end());
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: not a spilled event (CBOR): {}", where, e.what()));
  }
  auto field = [&](const char* k) -> const nlohmann::json& {
    if (!j.is_object() || !j.contains(k))
      throw InputError(fmt::format("{}: spilled event has no '{}'", where, k));
    return j.at(k);
  };
  try {
    if (field("schema") != "brakefit.spilled_event/1")
      throw InputError(fmt::format("{}: schema is not brakefit.spilled_event/1", where));
    EventRecord r;
    r.uid = field("uid").get<std::string>();
    r.created_unix_s = field("created_unix_s").get<std::int64_t>();
    r.source = field("source").get<std::string>();
    r.vehicle_id = field("vehicle_id").get<std::string>();
    r.bench = field("bench").get<std::string>();
    r.end_reason = field("end_reason").get<std::string>();
    r.flags = field("flags").get<std::string>();
    r.model_hash = field("model_hash").get<std::string>();
    r.pipeline_event_id = field("pipeline_event_id").get<std::int64_t>();
    r.t_start_ns = field("t_start_ns").get<std::int64_t>();
    r.t_end_ns = field("t_end_ns").get<std::int64_t>();
    r.points = field("points").get<std::int64_t>();
    r.calibration_toml = field("calibration_toml").get<std::string>();
    r.result_json = field("result_json").get<std::string>();
    r.sample_count = field("sample_count").get<std::int64_t>();
    const auto& bin = field("samples").get_binary();
    r.samples_blob.assign(bin.begin(), bin.end());
    if (r.sample_count < 0 ||
        r.samples_blob.size() != static_cast<std::size_t>(r.sample_count) * kRecord)
      throw InputError(fmt::format("{}: {} samples do not fill {} bytes", where, r.sample_count,
                                   r.samples_blob.size()));
    return r;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: spilled event: {}", where, e.what()));
  }
}

}  // namespace brakefit::daemon
