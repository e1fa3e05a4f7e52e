#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>

#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "core/model_io.hpp"
#include "core/train.hpp"

namespace brakefit::cli {

void add_train_command(CLI::App& app) {
  struct Opts {
    std::string config, out;
  };
  auto opts = std::make_shared<Opts>();
  auto* cmd =
      app.add_subcommand("train", "Generate the curve database and train the SOM and the MLP");
  cmd->add_option("--config", opts->config,
                  "training configuration (TOML); default: built-in settings");
  cmd->add_option("--out", opts->out, "model file to write")->required();
  cmd->callback([opts] {
    TrainConfig cfg;
    if (!opts->config.empty()) {
      try {
        cfg = parse_train_config(read_file(opts->config), opts->config);
      } catch (const InputError& e) {
        throw ExitError(kExitConfig, e.what());
      }
    }
    spdlog::info(
        "database: preset {}, {} curves, seed {}; SOM {}x{} {} {} on {} curves; MLP {} trainer",
        cfg.database.preset, cfg.database.n_curves, cfg.database.seed, cfg.som.rows, cfg.som.cols,
        som::to_string(cfg.som.algorithm), som::to_string(cfg.som.neighbourhood),
        to_string(cfg.som_input), mlp::to_string(cfg.mlp.trainer));
    Model m = train_model(cfg, log_progress);
    const std::string text = serialize_model(m);
    write_file(opts->out, text);
    std::cout << fmt::format(
        "model {}\n  hash {}\n  SOM qe {:.5f} te {:.4f}, {} of {} units labelled\n  MLP: {} "
        "network{}\n",
        opts->out, m.hash, m.som_qe, m.som_te,
        std::count_if(m.unit_hits.begin(), m.unit_hits.end(), [](std::size_t h) { return h > 0; }),
        m.unit_hits.size(), m.mlp.size(), m.mlp.size() == 1 ? "" : "s");
    for (const auto& r : m.mlp_report)
      std::cout << fmt::format("    {} epochs (best {}), validation mse {:.5f}{}\n", r.epochs,
                               r.best_epoch, r.validation_mse,
                               r.early_stopped ? " (early stopped)" : "");
  });
}

}  // namespace brakefit::cli
