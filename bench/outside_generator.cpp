#include "bench/outside_generator.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <utility>

#include "core/curve.hpp"
#include "core/pipeline/event_csv.hpp"

namespace brakefit::bench {

namespace {

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  if (!in) throw GeneratorError(fmt::format("{}: cannot read", p.string()));
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// d ln D / d ln Fz at load fz of the outside generator's tyres (their PDX1, PDX2, FZ0, as its
/// README publishes them): load transfer's h/L becomes the peak's change per m/s^2 through it.
double d_ln_d_per_ln_fz(const std::string& tyre, double fz_n) {
  struct Pdx {
    double fz0, pdx1, pdx2;
  };
  static const std::map<std::string, Pdx> tyres = {{"vw_185_80R14", {3800.0, 1.09, -0.079328}},
                                                   {"sedan_pac02", {3928.5, 1.1739, -0.16395}},
                                                   {"mf61_255_55", {6752.0, 1.1632, -0.11154}}};
  const auto it = tyres.find(tyre);
  if (it == tyres.end()) throw GeneratorError(fmt::format("generator C: unknown tyre '{}'", tyre));
  const Pdx& t = it->second;
  const double dfz = (fz_n - t.fz0) / t.fz0;
  return 1.0 + t.pdx2 * (fz_n / t.fz0) / (t.pdx1 + t.pdx2 * dfz);
}

/// The interpreter the script runs under (Debian's, where python3-numpy installs numpy).
constexpr const char* kPython = "/usr/bin/python3";

/// Two of the script's effects in one of its sets (a pair), by the script's own code.
constexpr const char* kPairScript = BRAKEFIT_SOURCE_DIR "/bench/gen_c_pair.py";

/// The script's vehicle: mass 3.4 Fz0 / g, this wheel's load Fz0 + m (h/L) a / 2.
constexpr double kLoadPerDecelPerHoverL = 1.7 / 9.81;

}  // namespace

std::string outside_generator_missing() {
  if (std::system(fmt::format("{} -c 'import numpy' >/dev/null 2>&1", kPython).c_str()) == 0)
    return {};
  return fmt::format("generator C imports numpy, which {} cannot: apt-get install python3-numpy",
                     kPython);
}

std::vector<gap::Run> outside_runs(const std::string& script, sim::Injection& inj,
                                   std::uint64_t seed) {
  namespace fs = std::filesystem;
  std::string dir_template = (fs::temp_directory_path() / "brakefit-genc-XXXXXX").string();
  if (!mkdtemp(dir_template.data()))
    throw GeneratorError("generator C: cannot make a temp directory");
  const fs::path dir = dir_template;
  struct Cleanup {
    fs::path d;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(d, ec);
    }
  } cleanup{dir};
  const bool ground = inj.condition == gap::Condition::Ground;
  const std::string effect = inj.effect == "misspecified" ? "misspec" : inj.effect;
  const bool has_magnitude = effect != "none" && effect != "misspec";
  if (inj.pair() && inj.magnitude2 != inj.magnitude)
    throw GeneratorError("generator C gives a set one magnitude: a pair's two must be equal");
  // A pair: the script's own set, through bench/gen_c_pair.py, with both effects switched on.
  const std::string what = inj.pair() ? fmt::format("'{}' '{}' --effects {},{}", kPairScript,
                                                    script, effect, inj.effect2)
                                      : fmt::format("'{}' --effect {}", script, effect);
  const std::string cmd =
      fmt::format("{} {} '{}' --bench {} --seed {}{} >/dev/null 2>'{}'", kPython, what,
                  dir.string(), ground ? "ground" : "roller", seed % 4'000'000'000ULL,
                  has_magnitude ? fmt::format(" --magnitude {:.9g}", inj.magnitude) : "",
                  (dir / "stderr").string());
  if (std::system(cmd.c_str()) != 0)
    throw GeneratorError(fmt::format("generator C failed: {}: {}", cmd, slurp(dir / "stderr")));
  const auto truth = nlohmann::json::parse(slurp(dir / "truth.json"));
  std::vector<gap::Run> out;
  double wheel_load_n = NAN;
  for (int k = 0; fs::exists(dir / fmt::format("run{}.csv", k)); ++k) {
    const std::string name = fmt::format("c{}", k);
    const std::string text = slurp(dir / fmt::format("run{}.csv", k));
    wheel_load_n = pipeline::parse_event_csv(text, name).calibration.wheel_load_n;
    sim::append_event_csv_runs(out, text, name);
  }
  // Each effect's truth in the diagnosis parameter's unit.
  for (auto [e, m] : {std::pair{&inj.effect, &inj.magnitude}, {&inj.effect2, &inj.magnitude2}}) {
    if (*e == "slip_offset") *m = -*m;
    if (*e == "load_transfer") {
      inj.load_per_decel = *m * kLoadPerDecelPerHoverL;
      *m *= kLoadPerDecelPerHoverL *
            d_ln_d_per_ln_fz(truth.at("tyre").get<std::string>(), wheel_load_n);
    }
  }
  return out;
}

}  // namespace brakefit::bench
