#include "sim/second/tir.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>

#include "core/curve.hpp"  // InputError

namespace brakefit::sim2 {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::string upper(std::string_view s) {
  std::string u(s);
  std::transform(u.begin(), u.end(), u.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return u;
}

/// The line without its '$' comment (a '$' inside quotes is kept).
std::string_view strip_comment(std::string_view line) {
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    if (line[i] == '\'' || line[i] == '"') quoted = !quoted;
    if (line[i] == '$' && !quoted) return line.substr(0, i);
  }
  return line;
}

}  // namespace

double TirFile::at(const std::string& section, const std::string& key) const {
  const auto s = numbers.find(section);
  if (s != numbers.end())
    if (const auto k = s->second.find(key); k != s->second.end()) return k->second;
  throw InputError(fmt::format("{}: [{}] {} missing", source, section, key));
}

double TirFile::get(const std::string& section, const std::string& key, double fallback) const {
  const auto s = numbers.find(section);
  if (s == numbers.end()) return fallback;
  const auto k = s->second.find(key);
  return k == s->second.end() ? fallback : k->second;
}

TirFile parse_tir(std::string_view text, const std::string& source) {
  TirFile f;
  f.source = source;
  std::string section;
  std::size_t pos = 0, line_no = 0;
  while (pos <= text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view raw = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++line_no;
    const std::string_view line = trim(strip_comment(raw));
    if (line.empty() || line.front() == '!') continue;
    auto fail = [&](const std::string& msg) {
      return InputError(fmt::format("{}:{}: {}", source, line_no, msg));
    };
    if (line.front() == '[') {
      if (line.back() != ']' || line.size() < 3) throw fail("a section header is [NAME]");
      section = upper(trim(line.substr(1, line.size() - 2)));
      continue;
    }
    const auto eq = line.find('=');
    if (eq == std::string_view::npos) throw fail(fmt::format("expected KEY = value: '{}'", line));
    const std::string key = upper(trim(line.substr(0, eq)));
    const std::string_view value = trim(line.substr(eq + 1));
    if (key.empty()) throw fail("empty key");
    if (section.empty()) throw fail(fmt::format("{} is outside any [SECTION]", key));
    if (!value.empty() && (value.front() == '\'' || value.front() == '"')) {
      if (value.size() < 2 || value.back() != value.front())
        throw fail(fmt::format("{}: unterminated string", key));
      f.strings[section][key] = std::string(value.substr(1, value.size() - 2));
      continue;
    }
    double x = 0;
    // Fortran-style exponents (1.0D-3) appear in older files.
    std::string v(value);
    std::replace(v.begin(), v.end(), 'D', 'e');
    std::replace(v.begin(), v.end(), 'd', 'e');
    const char* b = v.data();
    if (!v.empty() && v.front() == '+') ++b;
    const auto [end, ec] = std::from_chars(b, v.data() + v.size(), x);
    if (v.empty() || ec != std::errc() || end != v.data() + v.size() || !std::isfinite(x))
      throw fail(fmt::format("{}: '{}' is neither a number nor a quoted string", key, value));
    f.numbers[section][key] = x;
  }
  return f;
}

}  // namespace brakefit::sim2
