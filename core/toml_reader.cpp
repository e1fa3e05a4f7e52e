#include "core/toml_reader.hpp"

namespace brakefit {

toml::table parse_toml(std::string_view text, const std::string& source) {
  try {
    return toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    throw InputError(fmt::format("{}:{}:{}: {}", source, e.source().begin.line,
                                 e.source().begin.column, std::string(e.description())));
  }
}

}  // namespace brakefit
