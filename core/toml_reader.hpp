#pragma once
// Strict TOML reading shared by the configuration parsers: unknown keys, wrong types and values out
// of range throw InputError naming the source and the dotted key.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <toml++/toml.h>
#include <cstdint>
#include <set>
#include <string>
#include <string_view>

#include "core/curve.hpp"     // InputError
#include "core/curve_db.hpp"  // ParamRange

namespace brakefit {

/// Throws InputError "SOURCE:LINE:COL: ..." unless the text is valid UTF-8 without control
/// characters other than tab, CR and LF (toml++ 3.3.0 reaches an unreachable() on some such
/// input: upstream issue 295).
void check_plain_text(std::string_view text, const std::string& source);
/// Parses TOML text (after check_plain_text); syntax errors become InputError
/// "SOURCE:LINE:COL: ...".
toml::table parse_toml(std::string_view text, const std::string& source);

class TomlReader {
 public:
  explicit TomlReader(std::string source) : source_(std::move(source)) {}
  [[noreturn]] void fail(const std::string& key, const std::string& msg) const {
    throw InputError(fmt::format("{}: key '{}': {}", source_, key, msg));
  }
  void check_keys(const toml::table& t, const std::string& prefix,
                  const std::set<std::string>& allowed) const {
    for (const auto& [k, v] : t) {
      if (!allowed.count(std::string(k.str())))
        fail(prefix + std::string(k.str()),
             fmt::format("unknown key (allowed: {})", fmt::join(allowed, ", ")));
    }
  }
  double number(const toml::table& t, const std::string& prefix, const char* key, double def,
                double lo, double hi) const {
    const auto* node = t.get(key);
    if (!node) return def;
    double v = 0;
    if (auto i = node->value_exact<int64_t>())
      v = static_cast<double>(*i);
    else if (auto d = node->value_exact<double>())
      v = *d;
    else
      fail(prefix + key, "expected a number");
    if (!(v >= lo && v <= hi))
      fail(prefix + key, fmt::format("value {} is outside [{}, {}]", v, lo, hi));
    return v;
  }
  std::int64_t integer(const toml::table& t, const std::string& prefix, const char* key,
                       std::int64_t def, std::int64_t lo, std::int64_t hi) const {
    const auto* node = t.get(key);
    if (!node) return def;
    auto i = node->value_exact<int64_t>();
    if (!i) fail(prefix + key, "expected an integer");
    if (*i < lo || *i > hi)
      fail(prefix + key, fmt::format("value {} is outside [{}, {}]", *i, lo, hi));
    return *i;
  }
  std::string string(const toml::table& t, const std::string& prefix, const char* key,
                     const std::string& def) const {
    const auto* node = t.get(key);
    if (!node) return def;
    auto s = node->value_exact<std::string>();
    if (!s) fail(prefix + key, "expected a string");
    return *s;
  }
  ParamRange range(const toml::table& t, const std::string& prefix, const char* key) const {
    const auto* arr = t.get_as<toml::array>(key);
    if (!arr) fail(prefix + key, "expected a range [low, high]");
    if (arr->size() != 2) fail(prefix + key, "expected exactly two numbers [low, high]");
    ParamRange r;
    double* out[2] = {&r.lo, &r.hi};
    for (std::size_t i = 0; i < 2; ++i) {
      const auto& n = (*arr)[i];
      if (auto iv = n.value_exact<int64_t>())
        *out[i] = static_cast<double>(*iv);
      else if (auto dv = n.value_exact<double>())
        *out[i] = *dv;
      else
        fail(prefix + key, "range values must be numbers");
    }
    if (!(r.lo <= r.hi)) fail(prefix + key, "low must not exceed high");
    return r;
  }
  bool boolean(const toml::table& t, const std::string& prefix, const char* key, bool def) const {
    const auto* node = t.get(key);
    if (!node) return def;
    auto b = node->value_exact<bool>();
    if (!b) fail(prefix + key, "expected true or false");
    return *b;
  }
  const toml::table* table(const toml::table& t, const std::string& prefix, const char* key) const {
    const auto* node = t.get(key);
    if (!node) return nullptr;
    if (!node->is_table()) fail(prefix + key, "expected a table");
    return node->as_table();
  }
  const std::string& source() const { return source_; }

 private:
  std::string source_;
};

}  // namespace brakefit
