#pragma once
// JSON documents shared by the commands (every one carries schema, version and the model hash).
#include <nlohmann/json.hpp>

#include "core/identify.hpp"
#include "core/pipeline/pipeline.hpp"

namespace brakefit {

nlohmann::ordered_json num(double v);
/// One entry of "results": method, B, C, D, E, metrics, stderr or null.
nlohmann::ordered_json result_json(const MethodResult& r);
/// {"schema":"brakefit.event/1", "version", "model_hash", "file", "event_id", "bench", ...}.
nlohmann::ordered_json event_json(const pipeline::EventResult& e, const std::string& file,
                                  const Model* model);

}  // namespace brakefit
