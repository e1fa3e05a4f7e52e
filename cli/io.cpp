#include "cli/io.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "brakefit/version.hpp"
#include "core/model_io.hpp"

namespace brakefit::cli {

std::string read_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw ExitError(
        kExitNoInput,
        fmt::format("{}: is a directory; give the files in it (for example {}/*.csv)", path, path));
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw ExitError(kExitNoInput, fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw ExitError(kExitNoInput, fmt::format("{}: read error", path));
  return ss.str();
}

std::string count(std::size_t n, const std::string& noun) {
  return fmt::format("{} {}{}", n, noun, n == 1 ? "" : "s");
}

void make_parent_dir(const std::string& path) {
  const auto parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty() && !std::filesystem::exists(parent, ec))
    std::filesystem::create_directories(parent, ec);  // a failure is named by the write after
}

void write_file(const std::string& path, const std::string& content) {
  const std::string tmp = path + ".tmp";
  make_parent_dir(path);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out)
      throw ExitError(kExitCantCreate,
                      fmt::format("{}: cannot write: {}", path, std::strerror(errno)));
    out << content;
    out.flush();
    if (!out) throw ExitError(kExitCantCreate, fmt::format("{}: write failed", path));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw ExitError(kExitCantCreate,
                    fmt::format("{}: cannot rename into place: {}", path, std::strerror(errno)));
}

void make_output_dir(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw ExitError(kExitCantCreate,
                    fmt::format("{}: cannot create the output directory: {}", dir,
                                ec ? ec.message() : "a file of that name is in the way"));
}

std::string resolve_model_path(const std::string& given) {
  if (!given.empty()) return given;
  if (const char* env = std::getenv("BRAKEFIT_MODEL"); env && *env) return env;
  // Installed (the .deb, cmake --install): the model installed beside the binary,
  // <prefix>/bin/brakefit -> <prefix>/share/brakefit/models/default.json. In the build tree there
  // is none, and the source tree's data/models/default.json (compiled in) is used.
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto installed = exe.parent_path().parent_path() / "share/brakefit/models/default.json";
    if (std::filesystem::is_regular_file(installed, ec)) return installed.string();
  }
  return kDefaultModelPath;
}

Model load_model(const std::string& path) {
  const std::string text = read_file(path);
  try {
    return deserialize_model(text, path);
  } catch (const InputError& e) {
    throw ExitError(kExitDataError, e.what());
  }
}

void log_progress(const std::string& stage, std::size_t done, std::size_t total, double loss) {
  const std::size_t step = std::max<std::size_t>(1, total / 10);
  if (done % step != 0 && done != total) return;
  if (std::isnan(loss))
    spdlog::info("{}: {}/{} ({:.0f} %)", stage, done, total,
                 100.0 * static_cast<double>(done) / static_cast<double>(total));
  else
    spdlog::info("{}: epoch {}/{} training loss {:.5f}", stage, done, total, loss);
}

/// "2026-11-23T15:10:00Z" (UTC, ISO 8601).
std::string iso8601_utc(std::int64_t unix_s) {
  const auto t = static_cast<std::time_t>(unix_s);
  std::tm tm{};
  if (!gmtime_r(&t, &tm)) return std::to_string(unix_s);
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z", tm.tm_year + 1900, tm.tm_mon + 1,
                     tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec);
}

}  // namespace brakefit::cli
