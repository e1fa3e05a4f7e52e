#include "daemon/event_block.hpp"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>

namespace brakefit::daemon {

namespace {

double number_or_nan(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : std::nan("");
}

std::uint32_t hash_prefix(const nlohmann::json& hash) {
  if (!hash.is_string()) return 0;
  const auto s = hash.get<std::string>();
  const auto colon = s.find(':');
  const std::string hex = s.substr(colon == std::string::npos ? 0 : colon + 1, 8);
  try {
    return static_cast<std::uint32_t>(std::stoul(hex, nullptr, 16));
  } catch (...) {
    return 0;
  }
}

}  // namespace

std::uint16_t event_seq(std::int64_t id) {
  return static_cast<std::uint16_t>(static_cast<std::uint64_t>(id) & 0xFFFFu);
}

RegisterWrites event_block(const std::string& result_json, std::int64_t id, bool samples_stored) {
  const auto doc = nlohmann::json::parse(result_json);
  if (!doc.is_object() || !doc.contains("schema") || doc["schema"] != "brakefit.event/1")
    throw std::invalid_argument("stored result is not a brakefit.event/1 document");
  std::uint16_t flags = 0;
  for (const auto& f : doc.at("flags")) {
    if (f == "too_short") flags |= kFlagTooShort;
    if (f == "aborted") flags |= kFlagAborted;
    if (f == "sensor_fault") flags |= kFlagSensorFault;
    if (f == "edges_lost") flags |= kFlagEdgesLost;
    if (f == "implausible_data") flags |= kFlagImplausibleData;
  }
  // With a bench measurement model the tyre's fits are published (bit 9 says so); the bound and
  // plausibility bits describe the fits published.
  const bool tyre = doc.contains("tyre_results") && doc["tyre_results"].is_array() &&
                    !doc["tyre_results"].empty();
  const auto& results = tyre ? doc.at("tyre_results") : doc.at("results");
  if (tyre) flags |= kFlagTyreBasis;
  if (results.empty()) flags |= kFlagNotFitted;
  auto least_squares_has = [&](const char* key) {
    for (const auto& r : results)
      if (r.is_object() && r.contains(key) && r[key].is_array() && !r[key].empty() &&
          r.contains("method") && (r["method"] == "lm" || r["method"] == "hybrid"))
        return true;
    return false;
  };
  if (least_squares_has("at_bound")) flags |= kFlagAtBound;
  if (least_squares_has("implausible")) flags |= kFlagImplausibleResult;
  if (!samples_stored) flags |= kFlagSamplesNotStored;
  const std::uint16_t seq = event_seq(id);
  const auto t_start_ns = doc.at("t_start_ns").get<std::int64_t>();
  const auto t_end_ns = doc.at("t_end_ns").get<std::int64_t>();
  RegisterWrites w;
  w.u16("event.seq_begin", seq);
  w.u32("event.id", static_cast<std::uint32_t>(id));
  w.u16("event.bench", doc.at("bench") == "ground" ? 1 : 0);
  w.u16("event.flags", flags);
  w.u16("event.end_reason", end_reason_code(doc.at("end_reason").get<std::string>()));
  w.u32("event.duration_ms", static_cast<std::uint32_t>((t_end_ns - t_start_ns) / 1'000'000));
  w.u16("event.points", static_cast<std::uint16_t>(
                            std::min<std::int64_t>(doc.at("points").get<std::int64_t>(), 65535)));
  w.f32("event.peak_force_n", number_or_nan(doc, "max_force_n"));
  w.f32("event.peak_slip_ratio", number_or_nan(doc, "max_slip_ratio"));
  w.u32("event.model_hash", hash_prefix(doc.at("model_hash")));
  w.u32("event.t_end_unix_s", static_cast<std::uint32_t>(t_end_ns / 1'000'000'000));
  const char* fields[6] = {"B", "C", "D", "E", "mape_pct", "rmse_n"};
  for (const char* m : kMethodBlocks) {
    const nlohmann::json* r = nullptr;
    for (const auto& x : results)
      if (x.is_object() && x.contains("method") && x["method"] == m) r = &x;
    for (const char* f : fields)
      w.f32(fmt::format("event.{}.{}", m, f).c_str(), r ? number_or_nan(*r, f) : std::nan(""));
  }
  w.u16("event.seq", seq);
  return w;
}

}  // namespace brakefit::daemon
