#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>

#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "core/curve_csv.hpp"
#include "core/plot/svg.hpp"

namespace brakefit::cli {

void add_map_command(CLI::App& app) {
  struct Opts {
    std::string model, svg, curve;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd =
      app.add_subcommand("map", "Draw the SOM: U-matrix, hit counts and the BMU of a curve");
  cmd->add_option("--model", o->model,
                  "trained model (default: $BRAKEFIT_MODEL or the shipped model)");
  cmd->add_option("--svg", o->svg, "SVG file to write")->required();
  cmd->add_option("curve", o->curve, "curve CSV whose best-matching unit is marked");
  cmd->callback([o] {
    const Model m = load_model(resolve_model_path(o->model));
    plot::SomMap map;
    map.lattice = &m.som.lattice();
    map.umatrix = m.som.umatrix();
    map.hits = m.unit_hits;
    map.title = fmt::format("SOM {}x{} hexagonal ({} curves, {} input)", m.som.lattice().rows(),
                            m.som.lattice().cols(), m.config.database.n_curves,
                            to_string(m.config.som_input));
    map.subtitle =
        fmt::format("qe {:.4f}, te {:.4f}; model {}", m.som_qe, m.som_te, m.hash.substr(0, 19));
    if (!o->curve.empty()) {
      const ParsedCurve pc = parse_curve_csv(read_file(o->curve), o->curve);
      const SomEstimate e = identify_som(m, pc.curve);
      map.marked = e.bmu;
      map.marked_label = fmt::format("BMU {}{}", e.bmu, e.fallback ? " (nearest labelled)" : "");
      std::cout << fmt::format(
          "{}: BMU unit {} (row {}, col {}), {} database curves there; B {:.3f} C {:.4f} D {:.1f} "
          "E {:.4f}\n",
          o->curve, e.bmu, e.bmu / m.som.lattice().cols(), e.bmu % m.som.lattice().cols(),
          m.unit_hits[e.bmu], e.params.B, e.params.C, e.params.D, e.params.E);
    }
    write_file(o->svg, plot::render_svg(map));
    spdlog::info("SOM map written to {}", o->svg);
  });
}

}  // namespace brakefit::cli
