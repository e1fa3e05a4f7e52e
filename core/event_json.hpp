#pragma once
// JSON documents shared by the commands (every one carries schema, version and the model hash).
#include <nlohmann/json.hpp>

#include "core/identify.hpp"
#include "core/pipeline/pipeline.hpp"

namespace brakefit {

nlohmann::ordered_json num(double v);
/// One entry of "results": method, B, C, D, E, metrics, stderr or null.
nlohmann::ordered_json result_json(const MethodResult& r);
/// What a table or a legend must say beside a fit: "C at bound" for parameters that ended on a
/// bound, "peak beyond the data" only when the curve's maximum lies past the data's slip range.
/// Empty when there is nothing to say.
std::string result_notes(const MethodResult& r, double data_slip_max);
/// {"schema":"brakefit.event/1", "version", "model_hash", "file", "event_id", "bench", ...}.
nlohmann::ordered_json event_json(const pipeline::EventResult& e, const std::string& file,
                                  const Model* model);

}  // namespace brakefit
