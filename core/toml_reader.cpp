#include "core/toml_reader.hpp"

namespace brakefit {

void check_plain_text(std::string_view text, const std::string& source) {
  std::size_t line = 1, col = 1;
  auto fail = [&](const char* what) {
    throw InputError(fmt::format("{}:{}:{}: {}", source, line, col, what));
  };
  for (std::size_t i = 0; i < text.size(); ++col) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x80) {
      if (c == '\n') {
        ++line;
        col = 0;
      } else if ((c < 0x20 && c != '\t' && c != '\r') || c == 0x7F) {
        fail("control character (the file is not plain text)");
      }
      ++i;
      continue;
    }
    // UTF-8: lead byte, then continuation bytes; no overlongs, surrogates or values past U+10FFFF.
    const std::size_t n = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : c >= 0xC0 ? 2 : 0;
    if (n == 0 || c < 0xC2 || c > 0xF4 || i + n > text.size()) fail("invalid UTF-8");
    std::uint32_t cp = c & (0xFFu >> (n + 1));
    for (std::size_t k = 1; k < n; ++k) {
      const auto cc = static_cast<unsigned char>(text[i + k]);
      if ((cc & 0xC0) != 0x80) fail("invalid UTF-8");
      cp = (cp << 6) | (cc & 0x3Fu);
    }
    if ((n == 3 && cp < 0x800) || (n == 4 && (cp < 0x10000 || cp > 0x10FFFF)) ||
        (cp >= 0xD800 && cp <= 0xDFFF))
      fail("invalid UTF-8");
    i += n;
  }
}

toml::table parse_toml(std::string_view text, const std::string& source) {
  check_plain_text(text, source);
  try {
    return toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    throw InputError(fmt::format("{}:{}:{}: {}", source, e.source().begin.line,
                                 e.source().begin.column, std::string(e.description())));
  }
}

}  // namespace brakefit
