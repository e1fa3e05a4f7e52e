#include "bench/outside_generator.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <utility>

#include "core/curve.hpp"
#include "core/pipeline/event_csv.hpp"
#include "core/tyre/load_laws.hpp"
#include "core/tyre/tir_numbers.hpp"
#include "sim/second/tir.hpp"

namespace brakefit::bench {

namespace {

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  if (!in) throw GeneratorError(fmt::format("{}: cannot read", p.string()));
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The interpreter the script runs under (Debian's, where python3-numpy installs numpy).
constexpr const char* kPython = "/usr/bin/python3";

/// Two of the script's effects in one of its sets (a pair), by the script's own code.
constexpr const char* kPairScript = BRAKEFIT_SOURCE_DIR "/bench/gen_c_pair.py";

/// The script's tyres as MF 6.1 files (its own coefficients, read from its TYRES table).
constexpr const char* kTyreScript = BRAKEFIT_SOURCE_DIR "/bench/gen_c_tyres.py";

/// The script's tyres, written by bench/gen_c_tyres.py into dir and read once per script (a run of
/// the referee reads one script; its trials share the tyres).
const std::map<std::string, tyre::Mf61Tyre>& c_tyres(const std::string& script,
                                                     const std::filesystem::path& dir) {
  static std::mutex mutex;
  static std::map<std::string, std::map<std::string, tyre::Mf61Tyre>> read;
  const std::lock_guard lock(mutex);
  if (const auto it = read.find(script); it != read.end()) return it->second;
  const std::filesystem::path out = dir / "tyres";
  const std::string cmd = fmt::format("{} '{}' '{}' '{}' >/dev/null 2>'{}'", kPython, kTyreScript,
                                      script, out.string(), (dir / "stderr").string());
  if (std::system(cmd.c_str()) != 0)
    throw GeneratorError(fmt::format("generator C's tyres: {}: {}", cmd, slurp(dir / "stderr")));
  std::map<std::string, tyre::Mf61Tyre> tyres;
  for (const auto& f : std::filesystem::directory_iterator(out)) {
    const std::string source = f.path().string();
    try {
      tyres[f.path().stem().string()] =
          tyre::tyre_from_tir(sim2::parse_tir(slurp(f.path()), source).numbers, source);
    } catch (const InputError& e) {
      throw GeneratorError(fmt::format("generator C's tyre: {}", e.what()));
    }
  }
  return read.emplace(script, std::move(tyres)).first->second;
}

/// The load laws of the script's tyre `name` at fz_n.
tyre::LoadLaws c_tyre_laws(const std::string& script, const std::filesystem::path& dir,
                           const std::string& name, double fz_n) {
  const auto& tyres = c_tyres(script, dir);
  const auto it = tyres.find(name);
  if (it == tyres.end()) throw GeneratorError(fmt::format("generator C: unknown tyre '{}'", name));
  try {
    return tyre::load_laws_at(it->second, fz_n);
  } catch (const InputError& e) {
    throw GeneratorError(fmt::format("generator C's tyre {}: {}", name, e.what()));
  }
}

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
  // Each effect's truth in the diagnosis parameter's unit: load transfer's through the tyre's
  // own d ln D / d ln Fz.
  inj.tyre_laws = c_tyre_laws(script, dir, truth.at("tyre").get<std::string>(), wheel_load_n);
  for (auto [e, m] : {std::pair{&inj.effect, &inj.magnitude}, {&inj.effect2, &inj.magnitude2}}) {
    if (*e == "slip_offset") *m = -*m;
    if (*e == "load_transfer") {
      inj.load_per_decel = *m * kLoadPerDecelPerHoverL;
      *m *= kLoadPerDecelPerHoverL * inj.tyre_laws.peak_exponent;
    }
  }
  return out;
}

}  // namespace brakefit::bench
