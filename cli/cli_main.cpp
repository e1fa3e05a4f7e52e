#include "cli/cli_main.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <fmt/format.h>

#include <algorithm>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "brakefit/version.hpp"
#include "cli/io.hpp"

namespace brakefit::cli {

namespace {

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

/// The first word on the line that is not an option, when it names no subcommand: said with the
/// nearest subcommand (CLI11 alone says only that a subcommand is required).
std::optional<std::string> unknown_subcommand(CLI::App& app, int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word == "--log-level") {
      ++i;  // its value
      continue;
    }
    if (word.empty() || word[0] == '-') continue;
    std::string nearest;
    std::size_t best = std::string::npos;
    for (const auto* sub : app.get_subcommands({})) {
      if (sub->get_name() == word) return std::nullopt;
      const auto d = edit_distance(word, sub->get_name());
      if (d < best) {
        best = d;
        nearest = sub->get_name();
      }
    }
    return fmt::format("'{}' is not a brakefit subcommand{}; `brakefit --help` lists them", word,
                       best <= 3 ? fmt::format(" (did you mean '{}'?)", nearest) : "");
  }
  return std::nullopt;
}

}  // namespace

int run_cli(int argc, char** argv, const CliSetup& setup) {
  auto logger = spdlog::stderr_color_mt("brakefit");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  CLI::App app{setup.description, setup.name};
  app.set_version_flag("--version", std::string("brakefit ") + brakefit::kVersion);
  app.require_subcommand(1);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error|off")
      ->capture_default_str();
  app.parse_complete_callback([&] { spdlog::set_level(spdlog::level::from_str(log_level)); });
  // --log-level anywhere on the line, before the subcommand or after it (inherited by the
  // subcommands added after this).
  app.fallthrough();
  setup.add_commands(app);
  if (const auto unknown = unknown_subcommand(app, argc, argv)) {
    std::cerr << setup.name << ": error: " << *unknown << "\n";
    return brakefit::kExitUsage;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every other parse error is a usage error (sysexits 64), not
    // CLI11's own 105-115.
    return app.exit(e) == 0 ? 0 : brakefit::kExitUsage;
  } catch (const brakefit::cli::ExitError& e) {
    std::cerr << setup.name << ": error: " << e.what() << "\n";
    return e.code;
  } catch (const brakefit::InputError& e) {
    std::cerr << setup.name << ": error: " << e.what() << "\n";
    return brakefit::cli::kExitDataError;
  } catch (const std::exception& e) {
    std::cerr << setup.name << ": internal error: " << e.what() << "\n";
    return brakefit::kExitSoftware;
  }
  return 0;
}

}  // namespace brakefit::cli
