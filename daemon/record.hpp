#pragma once
// One finished event as the store keeps it (EventRecord), built once when the event finishes;
// it may wait in memory or spilled to a CBOR file until the store takes it.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/pipeline/pipeline.hpp"

namespace brakefit::daemon {

/// What the store keeps of one finished event: its row and its raw samples, built once when the
/// event finishes. It may wait (in memory, or spilled to a file) until the store takes it.
struct EventRecord {
  std::string uid;  ///< random, made once: a record committed twice (spill + crash) is found
  std::int64_t created_unix_s = 0;
  std::string source, vehicle_id, bench, end_reason, flags, model_hash;
  std::int64_t pipeline_event_id = 0, t_start_ns = 0, t_end_ns = 0, points = 0;
  std::string calibration_toml;
  std::string result_json;  ///< brakefit.event/1 document
  std::int64_t sample_count = 0;
  std::string samples_blob;  ///< pack_samples()
};

EventRecord make_record(const pipeline::EventResult& e, const std::string& result_json,
                        const std::string& calibration_toml, const std::string& vehicle_id,
                        const std::string& source, const std::string& model_hash,
                        std::int64_t now_unix_s);
/// A journaled record not fitted yet (the event closed, then the process died) has no result.
inline bool fitted(const EventRecord& r) {
  return !r.result_json.empty();
}
/// The closed event a record was made from (its samples, flags, end and bench), to be fitted.
pipeline::Event event_from_record(const EventRecord& r);

/// A record as CBOR (the spill file format) and back; the reader throws InputError naming
/// `where` on anything that is not a complete record.
std::string record_to_cbor(const EventRecord& r);
EventRecord record_from_cbor(std::string_view bytes, const std::string& where);

/// Raw samples <-> BLOB (little-endian records of 42 bytes).
std::string pack_samples(const std::vector<pipeline::Sample>& s);
std::vector<pipeline::Sample> unpack_samples(const void* data, std::size_t n);

}  // namespace brakefit::daemon
