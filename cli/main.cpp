// brakefit: identify Pacejka-96 brake-slip parameters (SOM, MLP, least squares, hybrid).
#include <cstdio>

#include "cli/cli_main.hpp"
#include "cli/commands.hpp"
#include "core/exit_codes.hpp"

int main(int argc, char** argv) {
  try {
    return brakefit::cli::run_cli(
        argc, argv,
        {"brakefit", "brakefit: Pacejka-96 brake-slip identification for roller brake testers",
         [](CLI::App& app) {
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
           brakefit::cli::add_tyre_command(app);
           brakefit::cli::add_sync_command(app);
           brakefit::cli::add_fleet_command(app);
         }});
  } catch (...) {  // setting up logging or the parser failed
    std::fputs("brakefit: internal error during start-up\n", stderr);
    return brakefit::kExitSoftware;
  }
}
