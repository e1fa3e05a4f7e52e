#include "bench/referee_results.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace brakefit::bench {

namespace {

std::string share(const nlohmann::ordered_json& c, const char* num, const char* den) {
  if (!c.contains(num) || !c.contains(den)) return "–";
  const int n = c[num].get<int>(), d = c[den].get<int>();
  if (d == 0) return "–";
  return n == d || n == 0 ? fmt::format("{}/{}", n, d)
                          : fmt::format("{}/{} = {:.1f} %", n, d, 100.0 * n / d);
}

double num(const nlohmann::ordered_json& j, const char* key) {
  return j.contains(key) && j[key].is_number() ? j[key].get<double>() : NAN;
}

/// A share in percent, "–" where nothing was measured.
std::string percent(double x) {
  return std::isfinite(x) ? fmt::format("{:.1f} %", 100 * x) : "–";
}

std::string row_name(const nlohmann::ordered_json& r) {
  const std::string trials = r["trial_generator"], gates = r["gate_generator"];
  return fmt::format("| {} | {} | {}{} ", r["condition"].get<std::string>(), trials, gates,
                     trials == gates ? "" : " (crossed)");
}

/// A row's item in a list under a table: "- condition trials, gates G: each".
std::string list_item(const nlohmann::ordered_json& r, const std::string& each) {
  return fmt::format("- {} {}, gates {}: {}\n", r["condition"].get<std::string>(),
                     r["trial_generator"].get<std::string>(),
                     r["gate_generator"].get<std::string>(), each);
}

/// One effect's misses in a list: "name below of missed", and those without a reach.
std::string misses_below_reach(const std::string& sep, const std::string& effect, int below,
                               int missed, int with_reach) {
  const int without = missed - with_reach;
  return fmt::format("{}{} {} of {}{}", sep, effect, below, missed,
                     without > 0 ? fmt::format(" ({} without a reach)", without) : "");
}

}  // namespace

std::string source_commit() {
  auto run = [](const std::string& cmd) {
    std::string out;
    std::unique_ptr<FILE, int (*)(FILE*)> p(popen(cmd.c_str(), "r"), pclose);
    if (!p) return out;
    std::array<char, 256> buf{};
    while (fgets(buf.data(), static_cast<int>(buf.size()), p.get())) out += buf.data();
    return out;
  };
  const std::string dir = BRAKEFIT_SOURCE_DIR;
  std::string head = run("git -C '" + dir + "' rev-parse --short HEAD 2>/dev/null");
  while (!head.empty() && (head.back() == '\n' || head.back() == ' ')) head.pop_back();
  if (head.empty()) return "unknown (not a git tree)";
  // The docs are left out: the results files the referee writes are among them, and a run
  // started while an earlier one's tables wait to be committed measures the same code.
  if (!run("git -C '" + dir + "' status --porcelain --untracked-files=no -- . ':!docs' 2>/dev/null")
           .empty())
    head += "-dirty";
  return head;
}

std::string results_markdown(const nlohmann::ordered_json& doc) {
  std::string out;
  if (!doc.contains("conditions")) return out;
  const auto& rows = doc["conditions"];
  const auto has_trials = [](const nlohmann::ordered_json& r) {
    return r["counts"].value("effects", 0) + r["counts"].value("null", 0) > 0;
  };
  if (std::any_of(rows.begin(), rows.end(), has_trials))
    out +=
        "| condition | trials | gates | effects correct | exactly first | false positives | null "
        "`[\"none\"]` | misspecified none/unexplained | refused | gap after / floor, median (p90) "
        "|\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : rows) {
    if (!has_trials(r)) continue;
    const auto& c = r["counts"];
    out += row_name(r) +
           fmt::format("| {} | {:.1f} % | {} | {} | {} | {} | {:.2f} ({:.2f}) |\n",
                       share(c, "correct", "effects"), 100 * num(r, "accuracy_effects_exact"),
                       share(c, "false_positives", "null"), share(c, "null_none", "null"),
                       share(c, "misspecified_ok", "misspecified"), c.value("refused", 0),
                       num(r["gap_after_over_noise"], "median"),
                       num(r["gap_after_over_noise"], "p90"));
  }
  // A row drew pairs where it has their effects (--only may leave a generator none: C draws no
  // pair with a time offset).
  const auto drew_pairs = [](const nlohmann::ordered_json& r) {
    return r["counts"].contains("pairs") && r["counts"]["pairs"].get<int>() > 0 &&
           r.contains("pair_effects");
  };
  bool pairs = false;
  for (const auto& r : rows) pairs |= drew_pairs(r);
  if (pairs) {
    out +=
        "\nPairs (two effects in one set; each effect: named / drawn, magnitude error where "
        "named, median):\n\n| condition | trials | gates | both named | exactly the two | each "
        "effect |\n|---|---|---|---|---|---|\n";
    for (const auto& r : rows) {
      const auto& c = r["counts"];
      if (!drew_pairs(r)) continue;
      std::string each;
      for (const auto& [e, v] : r["pair_effects"].items())
        each += fmt::format("{}{} {}/{}, {}", each.empty() ? "" : "; ", e, v["named"].get<int>(),
                            v["drawn"].get<int>(), percent(num(v, "magnitude_error_named_median")));
      out += row_name(r) + fmt::format("| {} | {} | {} |\n", share(c, "pairs_both", "pairs"),
                                       share(c, "pairs_exact", "pairs"), each);
    }
    // Each effect not named in its pair: how many lay below what the runs could show beside
    // the effects that were.
    std::string lines;
    for (const auto& r : rows) {
      if (!drew_pairs(r)) continue;
      std::string each;
      for (const auto& [e, v] : r["pair_effects"].items()) {
        const int missed = v["drawn"].get<int>() - v["named"].get<int>();
        if (missed == 0 || !v.contains("not_named_below_reach")) continue;
        each +=
            misses_below_reach(each.empty() ? "" : "; ", e, v["not_named_below_reach"].get<int>(),
                               missed, v["not_named_with_reach"].get<int>());
      }
      if (!each.empty()) lines += list_item(r, each);
    }
    if (!lines.empty())
      out +=
          "\nEffects of a pair not named by their own name, and of them below the smallest "
          "magnitude their runs could show beside the effects named (the report's reach):\n\n" +
          lines;
    // Each missed pair: what the pair search said of the true pair (gap --json's pairs_tried).
    std::string fates;
    for (const auto& r : rows) {
      if (!r.contains("pairs_missed_true_pair") || r["pairs_missed_true_pair"].empty()) continue;
      std::string each;
      for (const auto& [why, count] : r["pairs_missed_true_pair"].items())
        each += fmt::format("{}{} ({})", each.empty() ? "" : "; ", why, count.get<int>());
      fates += list_item(r, each);
    }
    if (!fates.empty())
      out +=
          "\nPairs missed, and what the pair search said of the true pair (the first rule it "
          "failed, or why it had none):\n\n" +
          fates;
  }
  if (std::any_of(rows.begin(), rows.end(),
                  [](const auto& r) { return r["counts"].contains("outside"); })) {
    out +=
        "\nOutside the catalogue (generator A's and B's sets with an effect the diagnosis has no "
        "name for: `none` or `unexplained` is right, a name is a false claim):\n\n| condition | "
        "trials | gates | none/unexplained | each effect | named instead |\n|---|---|---|---|---|"
        "---|\n";
    for (const auto& r : rows) {
      const auto& c = r["counts"];
      if (!c.contains("outside")) continue;
      std::string each, claimed;
      for (const auto& [e, v] : r["outside_effects"].items())
        each += fmt::format("{}{} {}/{}", each.empty() ? "" : "; ", e,
                            v["none_or_unexplained"].get<int>(), v["drawn"].get<int>());
      for (const auto& [e, n] : r["outside_claimed"].items())
        claimed += fmt::format("{}{} {}", claimed.empty() ? "" : ", ", e, n.get<int>());
      out += row_name(r) +
             fmt::format("| {} ({} `unexplained`) | {} | {} |\n", share(c, "outside_ok", "outside"),
                         c.value("outside_unexplained", 0), each, claimed.empty() ? "–" : claimed);
    }
  }
  bool detection = false;
  for (const auto& r : rows) detection |= r.contains("detection");
  if (detection) {
    out +=
        "\nDetection (sets that name the effect at each magnitude, in the parameter's unit; the "
        "smallest magnitude from which 90 % or more are named):\n\n| condition | trials | "
        "gates | effect | named at each magnitude | named in 90 % from "
        "|\n|---|---|---|---|---|---|\n";
    for (const auto& r : rows) {
      if (!r.contains("detection")) continue;
      for (const auto& [e, v] : r["detection"].items()) {
        std::string cells;
        for (const auto& p : v["curve"])
          cells += fmt::format("{}{:.3g}: {}/{}", cells.empty() ? "" : ", ",
                               p["magnitude"].get<double>(), p["named"].get<int>(),
                               p["sets"].get<int>());
        const double from = num(v, "smallest_named_90");
        out += row_name(r) +
               fmt::format("| {} | {} | {} |\n", e, cells,
                           std::isfinite(from) ? fmt::format("{:.3g}", from) : "not reached");
      }
    }
  }
  if (std::any_of(rows.begin(), rows.end(),
                  [](const auto& r) { return r.contains("magnitude_error_named"); }))
    out += "\nMagnitude error where named, single effects, median (p90):\n\n";
  for (const auto& r : rows) {
    if (!r.contains("magnitude_error_named")) continue;
    std::string each;
    for (const auto& [e, v] : r["magnitude_error_named"].items())
      each += fmt::format("{}{} {} ({})", each.empty() ? "" : "; ", e, percent(num(v, "median")),
                          percent(num(v, "p90")));
    if (r.contains("load_ratio_error_named"))
      each += fmt::format("; load transfer as dFz/Fz per m/s^2 {} ({})",
                          percent(num(r["load_ratio_error_named"], "median")),
                          percent(num(r["load_ratio_error_named"], "p90")));
    if (r.contains("load_ratio_inside_published_band")) {
      const auto& band = r["load_ratio_inside_published_band"];
      each += fmt::format(", the truth inside the band of published tyres' laws in {} of {}",
                          band.value("inside", 0), band.value("of", 0));
    }
    out += list_item(r, each);
  }
  // Each row's misses: how many lay below the smallest magnitude their runs could show.
  bool any_missed = false;
  for (const auto& r : rows) any_missed |= r.contains("missed");
  if (any_missed)
    out +=
        "\nSingle effects missed, and of them below the smallest magnitude their runs could show "
        "(the report's reach, where the effect is not named):\n\n";
  for (const auto& r : rows) {
    if (!r.contains("missed")) continue;
    std::string each;
    for (const auto& [e, v] : r["missed"].items())
      each += misses_below_reach(each.empty() ? "" : "; ", e, v["below_reach"].get<int>(),
                                 v["sets"].get<int>(), v["with_reach"].get<int>());
    out += list_item(r, each);
  }
  return out;
}

void write_results_section(const std::string& file, const std::string& key,
                           const std::string& command, const std::string& commit, double minutes,
                           const std::string& body) {
  std::string text;
  {
    std::ifstream in(file);
    if (in) {
      std::stringstream ss;
      ss << in.rdbuf();
      text = ss.str();
    }
  }
  const std::string begin = fmt::format("<!-- gap_referee {} begin -->", key),
                    end = fmt::format("<!-- gap_referee {} end -->", key);
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::array<char, 32> date{};
  std::strftime(date.data(), date.size(), "%Y-%m-%d", std::gmtime(&now));
  const std::string section =
      fmt::format("{}\n<!-- written by `{}` at commit {} ({}, {:.0f} min) -->\n\n{}{}", begin,
                  command, commit, date.data(), minutes, body, end);
  const auto b = text.find(begin);
  const auto e = b == std::string::npos ? std::string::npos : text.find(end, b);
  if (b != std::string::npos && e != std::string::npos)
    text.replace(b, e + end.size() - b, section);
  else
    text += (text.empty() || text.back() == '\n' ? "\n" : "\n\n") + section + "\n";
  std::ofstream out(file, std::ios::trunc);
  out << text;
  if (!out) throw std::runtime_error("gap_referee: cannot write the results file " + file);
}

}  // namespace brakefit::bench
