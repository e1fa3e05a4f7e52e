#pragma once
// The command line's frame, shared by brakefit and brakefit-sync: logging, --log-level anywhere,
// --version, an unknown subcommand named with the nearest, and every error mapped to its exit
// code (README's table).
#include <CLI/CLI.hpp>
#include <functional>
#include <string>

namespace brakefit::cli {

struct CliSetup {
  std::string name;         ///< the program's name in messages
  std::string description;  ///< --help's first line
  std::function<void(CLI::App&)> add_commands;
};

/// Parses argv and runs the chosen subcommand; returns the exit code.
int run_cli(int argc, char** argv, const CliSetup& setup);

}  // namespace brakefit::cli
