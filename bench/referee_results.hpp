#pragma once
// The referee writes its own results file: the tables of a run, with the command and the commit
// at their head, in a section of a Markdown file that a later run of the same key replaces.
#include <nlohmann/json.hpp>
#include <string>

namespace brakefit::bench {

/// The run's tables (single effects, pairs, magnitude errors) from its brakefit.gap_referee/1
/// document.
std::string results_markdown(const nlohmann::ordered_json& doc);

/// `git rev-parse --short HEAD` of the source tree the referee was built from, "-dirty" when it
/// has changes to tracked files outside docs/ (taken when the run starts).
std::string source_commit();

/// Puts body into file between `<!-- gap_referee KEY begin -->` and `<!-- gap_referee KEY end
/// -->` (replacing what was there, or appended), with the command, the commit, the date and the
/// run's minutes at its head. Throws std::runtime_error naming the file on failure.
void write_results_section(const std::string& file, const std::string& key,
                           const std::string& command, const std::string& commit, double minutes,
                           const std::string& body);

}  // namespace brakefit::bench
