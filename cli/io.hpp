#pragma once
// File I/O for the CLI (core stays free of I/O) and its exit codes.
#include <cstdint>
#include <stdexcept>
#include <string>

#include "core/exit_codes.hpp"
#include "core/identify.hpp"
#include "core/pipeline/calibration.hpp"

namespace brakefit::cli {

using brakefit::ExitError;
using brakefit::kExitCantCreate;
using brakefit::kExitConfig;
using brakefit::kExitDataError;
using brakefit::kExitNoInput;
using brakefit::kExitUsage;

std::string read_file(const std::string& path);
/// "1 run", "3 runs": a count with its noun.
std::string count(std::size_t n, const std::string& noun);
/// "2026-11-23T15:10:00Z" (UTC, ISO 8601).
std::string iso8601_utc(std::int64_t unix_s);
/// Writes via a temporary file and rename, so a reader never sees half a file.
void write_file(const std::string& path, const std::string& content);
/// Creates the directory an output goes in when it does not exist yet (out/fit.svg on a fresh
/// clone); an output under a file still fails at its write, naming the path.
void make_parent_dir(const std::string& path);
/// Creates an output directory (and its parents); ExitError 73 naming it and the system's reason.
void make_output_dir(const std::string& dir);
/// The model given, else $BRAKEFIT_MODEL, else the installed default model
/// (<prefix>/share/brakefit/models/) or, in the build tree, the one in data/models/.
std::string resolve_model_path(const std::string& given);
Model load_model(const std::string& path);
using pipeline::recording_stem;
/// Logs a stage's progress at most every 10 %.
void log_progress(const std::string& stage, std::size_t done, std::size_t total, double loss);

}  // namespace brakefit::cli
