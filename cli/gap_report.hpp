#pragma once
// What `brakefit gap` writes of a diagnosis: its brakefit.gap/1 JSON, and the HTML report with
// the residual map and the curves before and after the named effects.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/recording.hpp"
#include "core/gap/gap.hpp"

namespace brakefit::cli {

/// The brakefit.gap/1 document of a diagnosis (mode: "gap" or "roller_vs_road"; roller_runs and
/// left_out only where they apply), carrying the model's hash and the gates it was judged by.
nlohmann::ordered_json report_json(const gap::Report& r, const std::vector<gap::Run>& runs,
                                   const std::vector<gap::Run>& roller_runs,
                                   const std::vector<LeftOut>& left_out,
                                   const std::string& model_hash, const std::string& mode,
                                   gap::Condition condition, const gap::Options& gates);

/// The report into dir: residual.svg, curves.svg, gap.json (doc) and index.html.
void write_report(const std::string& dir, const gap::Report& r, const std::vector<gap::Run>& runs,
                  const nlohmann::ordered_json& doc);

}  // namespace brakefit::cli
