// brakefit-sync: `brakefit sync` without the fitting libraries. The station's shipping service
// starts it (systemd/brakefit-sync.service): a process that talks to the network links only the
// store, the fleet path and libpq, not Ceres, BLAS or the simulators, and starts in half the time.
#include <cstdio>
#include <string>
#include <vector>

#include "cli/cli_main.hpp"
#include "cli/commands.hpp"
#include "core/exit_codes.hpp"

int main(int argc, char** argv) {
  try {
    // brakefit-sync ARGS is brakefit sync ARGS.
    std::vector<char*> args{argv[0], const_cast<char*>("sync")};
    args.insert(args.end(), argv + 1, argv + argc);
    return brakefit::cli::run_cli(static_cast<int>(args.size()), args.data(),
                                  {"brakefit-sync",
                                   "brakefit-sync: ship the station's stored events to the central "
                                   "PostgreSQL (brakefit sync)",
                                   [](CLI::App& app) { brakefit::cli::add_sync_command(app); }});
  } catch (...) {
    std::fputs("brakefit-sync: internal error during start-up\n", stderr);
    return brakefit::kExitSoftware;
  }
}
