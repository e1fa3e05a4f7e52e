// brakefit: identify Pacejka-96 brake-slip parameters (SOM, MLP, least squares, hybrid).
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>

#include "brakefit/version.hpp"
#include "cli/commands.hpp"
#include "cli/io.hpp"

namespace {

int run(int argc, char** argv) {
  auto logger = spdlog::stderr_color_mt("brakefit");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  CLI::App app{"brakefit: Pacejka-96 brake-slip identification for roller brake testers"};
  app.set_version_flag("--version", std::string("brakefit ") + brakefit::kVersion);
  app.require_subcommand(1);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error|off")
      ->capture_default_str();
  app.parse_complete_callback([&] { spdlog::set_level(spdlog::level::from_str(log_level)); });
  brakefit::cli::add_train_command(app);
  brakefit::cli::add_fit_command(app);
  brakefit::cli::add_map_command(app);
  brakefit::cli::add_synth_command(app);
  brakefit::cli::add_simulate_command(app);
  brakefit::cli::add_replay_command(app);
  brakefit::cli::add_export_command(app);
  brakefit::cli::add_compare_command(app);
  brakefit::cli::add_events_command(app);
  brakefit::cli::add_gap_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every other parse error is a usage error (sysexits 64), not
    // CLI11's own 105-115.
    return app.exit(e) == 0 ? 0 : brakefit::kExitUsage;
  } catch (const brakefit::cli::ExitError& e) {
    std::cerr << "brakefit: error: " << e.what() << "\n";
    return e.code;
  } catch (const brakefit::InputError& e) {
    std::cerr << "brakefit: error: " << e.what() << "\n";
    return brakefit::cli::kExitDataError;
  } catch (const std::exception& e) {
    std::cerr << "brakefit: internal error: " << e.what() << "\n";
    return brakefit::kExitSoftware;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (...) {  // setting up logging or the parser failed
    std::fputs("brakefit: internal error during start-up\n", stderr);
    return brakefit::kExitSoftware;
  }
}
