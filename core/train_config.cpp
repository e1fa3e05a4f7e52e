#include "core/train_config.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <toml++/toml.h>
#include <set>

#include "core/curve.hpp"
#include "core/toml_reader.hpp"

namespace brakefit {

const char* to_string(SomInput s) {
  return s == SomInput::Shape ? "shape" : "raw";
}

TrainConfig parse_train_config(std::string_view text, const std::string& source) {
  const toml::table root = parse_toml(text, source);
  TomlReader rd(source);
  rd.check_keys(root, "", {"database", "som", "mlp"});
  TrainConfig c;
  if (const auto* db = root.get_as<toml::table>("database")) {
    rd.check_keys(*db, "database.", {"preset", "seed", "curves", "family"});
    const std::string preset = rd.string(*db, "database.", "preset", "default");
    try {
      c.database = database_preset(preset);
    } catch (const InputError& e) {
      rd.fail("database.preset", e.what());
    }
    c.database.seed =
        static_cast<std::uint64_t>(rd.integer(*db, "database.", "seed", 20261121, 0, INT64_MAX));
    c.database.n_curves =
        static_cast<std::size_t>(rd.integer(*db, "database.", "curves", 2000, 10, 1000000));
    if (const auto* node = db->get("family")) {
      const auto* arr = node->as_array();
      if (!arr || !arr->is_array_of_tables())
        rd.fail("database.family", "expected [[database.family]] tables");
      c.database.families.clear();
      for (std::size_t i = 0; i < arr->size(); ++i) {
        const auto& t = *(*arr)[i].as_table();
        const std::string p = fmt::format("database.family[{}].", i);
        rd.check_keys(t, p, {"name", "weight", "B", "C", "D_n", "E"});
        TyreFamily f;
        f.name = rd.string(t, p, "name", fmt::format("family{}", i));
        f.weight = rd.number(t, p, "weight", 1.0, 0.0, 1e9);
        f.B = rd.range(t, p, "B");
        f.C = rd.range(t, p, "C");
        f.D_n = rd.range(t, p, "D_n");
        f.E = rd.range(t, p, "E");
        if (f.B.lo <= 0) rd.fail(p + "B", "B must be positive");
        if (f.D_n.lo <= 0) rd.fail(p + "D_n", "D_n must be positive");
        c.database.families.push_back(f);
      }
      if (c.database.families.empty()) rd.fail("database.family", "at least one family is needed");
    }
  }
  if (const auto* s = root.get_as<toml::table>("som")) {
    const std::string p = "som.";
    rd.check_keys(
        *s, p,
        {"rows", "cols", "input", "init", "algorithm", "neighbourhood", "rough_epochs",
         "fine_epochs", "rough_radius", "fine_radius", "rough_alpha", "fine_alpha", "seed"});
    c.som.rows = static_cast<std::size_t>(rd.integer(*s, p, "rows", 10, 2, 200));
    c.som.cols = static_cast<std::size_t>(rd.integer(*s, p, "cols", 10, 2, 200));
    const std::string input = rd.string(*s, p, "input", "shape");
    if (input == "shape")
      c.som_input = SomInput::Shape;
    else if (input == "raw")
      c.som_input = SomInput::Raw;
    else
      rd.fail(p + "input", "expected 'shape' or 'raw'");
    if (!som::parse(rd.string(*s, p, "init", "random"), c.som.init))
      rd.fail(p + "init", "expected 'random' or 'linear'");
    if (!som::parse(rd.string(*s, p, "algorithm", "batch"), c.som.algorithm))
      rd.fail(p + "algorithm", "expected 'batch' or 'sequential'");
    if (!som::parse(rd.string(*s, p, "neighbourhood", "gaussian"), c.som.neighbourhood))
      rd.fail(p + "neighbourhood", "expected 'gaussian', 'cutgauss', 'ep' or 'bubble'");
    c.som.rough.epochs =
        static_cast<std::size_t>(rd.integer(*s, p, "rough_epochs", 1000, 0, 1000000));
    c.som.fine.epochs = static_cast<std::size_t>(rd.integer(*s, p, "fine_epochs", 500, 0, 1000000));
    if (s->get("rough_radius")) {
      const auto r = rd.range(*s, p, "rough_radius");
      c.som.rough.radius_ini = r.hi;
      c.som.rough.radius_fin = r.lo;
    }
    if (s->get("fine_radius")) {
      const auto r = rd.range(*s, p, "fine_radius");
      c.som.fine.radius_ini = r.hi;
      c.som.fine.radius_fin = r.lo;
    }
    c.som.rough.alpha_ini = rd.number(*s, p, "rough_alpha", 0.5, 0.0, 1.0);
    c.som.fine.alpha_ini = rd.number(*s, p, "fine_alpha", 0.05, 0.0, 1.0);
    c.som.seed = static_cast<std::uint64_t>(rd.integer(*s, p, "seed", 1, 0, INT64_MAX));
  }
  if (const auto* m = root.get_as<toml::table>("mlp")) {
    const std::string p = "mlp.";
    rd.check_keys(
        *m, p,
        {"hidden", "trainer", "max_epochs", "validation_fraction", "patience", "learning_rate",
         "momentum", "truncate_fraction", "truncate_range", "seed", "ensemble"});
    if (const auto* h = m->get("hidden")) {
      const auto* arr = h->as_array();
      if (!arr || arr->empty()) rd.fail(p + "hidden", "expected a non-empty array of layer sizes");
      c.mlp.hidden.clear();
      for (const auto& n : *arr) {
        auto v = n.value_exact<int64_t>();
        if (!v || *v < 1 || *v > 4096)
          rd.fail(p + "hidden", "layer sizes must be integers in [1, 4096]");
        c.mlp.hidden.push_back(static_cast<std::size_t>(*v));
      }
    }
    if (!mlp::parse(rd.string(*m, p, "trainer", "rprop"), c.mlp.trainer))
      rd.fail(p + "trainer", "expected 'rprop', 'gd' or 'lm'");
    c.mlp.max_epochs = static_cast<std::size_t>(rd.integer(*m, p, "max_epochs", 1500, 1, 10000000));
    c.mlp.validation_fraction = rd.number(*m, p, "validation_fraction", 0.15, 0.0, 0.9);
    c.mlp.patience = static_cast<std::size_t>(rd.integer(*m, p, "patience", 150, 1, 10000000));
    c.mlp.learning_rate = rd.number(*m, p, "learning_rate", 0.05, 0.0, 10.0);
    c.mlp.momentum = rd.number(*m, p, "momentum", 0.9, 0.0, 0.999);
    c.mlp_truncate_fraction = rd.number(*m, p, "truncate_fraction", 0.5, 0.0, 1.0);
    if (m->get("truncate_range")) {
      const auto r = rd.range(*m, p, "truncate_range");
      if (r.lo <= 0 || r.hi > 1) rd.fail(p + "truncate_range", "slip ratios must lie in (0, 1]");
      c.mlp_truncate_min_ratio = r.lo;
      c.mlp_truncate_max_ratio = r.hi;
    }
    c.mlp.seed = static_cast<std::uint64_t>(rd.integer(*m, p, "seed", 2, 0, INT64_MAX));
    c.mlp_ensemble = static_cast<std::size_t>(rd.integer(*m, p, "ensemble", 5, 1, 64));
  }
  return c;
}

std::string format_train_config(const TrainConfig& c) {
  // Numbers printed with round-trip precision so a model file re-creates its settings exactly.
  auto r = [](const ParamRange& pr) { return fmt::format("[{}, {}]", pr.lo, pr.hi); };
  std::string s;
  s += "[database]\n";
  s += fmt::format("preset = \"{}\"\nseed = {}\ncurves = {}\n", c.database.preset, c.database.seed,
                   c.database.n_curves);
  for (const auto& f : c.database.families) {
    s += fmt::format(
        "\n[[database.family]]\nname = \"{}\"\nweight = {}\nB = {}\nC = {}\nD_n = {}\nE = {}\n",
        f.name, fmt::format("{:.17g}", f.weight), r(f.B), r(f.C), r(f.D_n), r(f.E));
  }
  const auto& m = c.som;
  s += "\n[som]\n";
  s += fmt::format(
      "rows = {}\ncols = {}\ninput = \"{}\"\ninit = \"{}\"\nalgorithm = \"{}\"\nneighbourhood = "
      "\"{}\"\n",
      m.rows, m.cols, to_string(c.som_input), som::to_string(m.init), som::to_string(m.algorithm),
      som::to_string(m.neighbourhood));
  s += fmt::format("rough_epochs = {}\nfine_epochs = {}\n", m.rough.epochs, m.fine.epochs);
  if (m.rough.radius_ini > 0)
    s += fmt::format("rough_radius = [{}, {}]\n", m.rough.radius_fin, m.rough.radius_ini);
  if (m.fine.radius_ini > 0)
    s += fmt::format("fine_radius = [{}, {}]\n", m.fine.radius_fin, m.fine.radius_ini);
  s += fmt::format("rough_alpha = {}\nfine_alpha = {}\nseed = {}\n", m.rough.alpha_ini,
                   m.fine.alpha_ini, m.seed);
  const auto& n = c.mlp;
  s += "\n[mlp]\n";
  s += fmt::format(
      "hidden = [{}]\ntrainer = \"{}\"\nmax_epochs = {}\nvalidation_fraction = {}\npatience = {}\n",
      fmt::join(n.hidden, ", "), mlp::to_string(n.trainer), n.max_epochs, n.validation_fraction,
      n.patience);
  s += fmt::format(
      "learning_rate = {}\nmomentum = {}\ntruncate_fraction = {}\ntruncate_range = [{}, {}]\nseed "
      "= {}\nensemble = {}\n",
      n.learning_rate, n.momentum, c.mlp_truncate_fraction, c.mlp_truncate_min_ratio,
      c.mlp_truncate_max_ratio, n.seed, c.mlp_ensemble);
  // Integers that look like floats must stay floats in TOML ("weight = 1" would re-parse as an
  // integer, which is accepted for numbers), so nothing more is needed here.
  return s;
}

}  // namespace brakefit
