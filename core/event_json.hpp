#pragma once
// JSON documents shared by the commands (every one carries schema, version and the model hash).
#include <nlohmann/json.hpp>

#include "core/identify.hpp"
#include "core/pipeline/pipeline.hpp"

namespace brakefit {

nlohmann::ordered_json num(double v);
/// One entry of "results": method, B, C, D, E, metrics, stderr or null.
nlohmann::ordered_json result_json(const MethodResult& r);
/// The fitted curve peaks past the data's slip range but below 100 % slip (not reached in the
/// data, and an interior maximum on [0, 1]); a curve still rising at 100 % has no peak to place.
bool peak_beyond_data(const MethodResult& r);
/// What a table or a legend must say beside a fit: "C at bound" for parameters that ended on a
/// bound, "peak beyond the data" when peak_beyond_data. Empty when there is nothing to say.
std::string result_notes(const MethodResult& r);
/// The notes of results[i], and the methods whose curve is the same (B, C, D, E within 1e-6): a
/// least-squares fit and the hybrid often end on one optimum, and one line hides the other.
std::string result_notes(const std::vector<MethodResult>& results, std::size_t i);
/// {"schema":"brakefit.event/1", "version", "model_hash", "file", "event_id", "bench", ...}.
nlohmann::ordered_json event_json(const pipeline::EventResult& e, const std::string& file,
                                  const Model* model);

}  // namespace brakefit
