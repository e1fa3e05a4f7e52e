// brakefitd: the brake tester data-acquisition daemon.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/sinks/systemd_sink.h>
#include <spdlog/spdlog.h>
#include <systemd/sd-daemon.h>
#include <CLI/CLI.hpp>
#include <csignal>
#include <cstring>
#include <iostream>

#include "brakefit/version.hpp"
#include "daemon/daemon.hpp"
#include "daemon/registers.hpp"

namespace {
brakefit::daemon::Signals g_signals;
extern "C" void on_signal(int sig) {
  if (sig == SIGHUP)
    g_signals.reload = true;
  else
    g_signals.stop = true;
}

int run(int argc, char** argv) {
  using namespace brakefit::daemon;
  using brakefit::kExitConfig;
  using brakefit::kExitSoftware;
  using brakefit::kExitUsage;
  CLI::App app{"brakefitd: roller brake tester data acquisition, fitting and Modbus publishing"};
  std::string config_path = "/etc/brakefit/brakefitd.toml";
  bool check = false, print_map = false;
  app.add_option("-c,--config", config_path, "TOML configuration")->capture_default_str();
  app.add_flag("--check", check, "validate the configuration, load the model it names, and exit");
  app.add_flag("--print-register-map", print_map,
               "print the Modbus register map as CSV (config/modbus_registers.csv) and exit");
  app.set_version_flag("--version", fmt::format("brakefitd {}", brakefit::kVersion));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : kExitUsage;  // --help/--version 0; else usage (64)
  }
  // Under systemd (stderr is the journal) levels go to the journal as priorities; else stderr.
  if (std::getenv("JOURNAL_STREAM")) {
    spdlog::set_default_logger(std::make_shared<spdlog::logger>(
        "brakefitd", std::make_shared<spdlog::sinks::systemd_sink_st>("brakefitd")));
    spdlog::set_pattern("%v");
  } else {
    spdlog::set_default_logger(spdlog::stderr_color_mt("brakefitd"));
    spdlog::set_pattern("%^%l%$ %v");
  }
  if (print_map) {
    std::cout << format_register_csv();
    return 0;
  }

  Config cfg;
  try {
    cfg = load_config(config_path);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return kExitConfig;
  }
  if (check) {
    // The model too: a config that names a missing or damaged model would pass and then stop the
    // service at start (ExecStartPre runs this check).
    try {
      const auto model = Daemon::load_model(cfg.model_path);
      std::cout << config_path << ": ok"
                << (model ? fmt::format(" (model {}, {})", cfg.model_path, model->hash) : "")
                << '\n';
    } catch (const DaemonError& e) {
      spdlog::error("{}: {}", config_path, e.what());
      return e.code;
    }
    return 0;
  }
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGHUP, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
  try {
    Daemon d(config_path, std::move(cfg), g_signals);
    return d.run();
  } catch (const DaemonError& e) {
    spdlog::error("{}", e.what());
    sd_notifyf(0, "STATUS=failed: %s", e.what());
    return e.code;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return kExitSoftware;
  }
}
}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {  // setting up the options or the logger: a bug
    std::cerr << "brakefitd: internal error: " << e.what() << '\n';
  } catch (...) {
    std::cerr << "brakefitd: internal error\n";
  }
  return brakefit::kExitSoftware;
}
