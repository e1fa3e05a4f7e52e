#pragma once
#include <CLI/CLI.hpp>
#include <string>

namespace brakefit::cli {

void add_train_command(CLI::App& app);
void add_fit_command(CLI::App& app);
void add_map_command(CLI::App& app);
void add_synth_command(CLI::App& app);
void add_simulate_command(CLI::App& app);
void add_replay_command(CLI::App& app);
void add_export_command(CLI::App& app);
void add_compare_command(CLI::App& app);
void add_events_command(CLI::App& app);
void add_gap_command(CLI::App& app);
void add_tyre_command(CLI::App& app);
void add_sync_command(CLI::App& app);
void add_fleet_command(CLI::App& app);

}  // namespace brakefit::cli
