#include "cli/fleet_connect.hpp"

#include <fmt/format.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "cli/io.hpp"
#include "fleet/pg.hpp"

namespace brakefit::cli {

std::string read_password_file(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw ExitError(kExitNoInput, fmt::format("{}: cannot read the password file", path));
  std::stringstream ss;
  ss << f.rdbuf();
  std::string pw = ss.str();
  while (!pw.empty() && (pw.back() == '\n' || pw.back() == '\r')) pw.pop_back();
  return pw;
}

std::map<std::string, std::string> fleet_settings(const std::string& url,
                                                  const std::string& password_file,
                                                  const std::string& application_name) {
  if (fleet::carries_password(url))
    throw ExitError(
        kExitUsage,
        "the central server's URL carries a password: give it in --password-file or "
        "$BRAKEFIT_FLEET_PASSWORD instead (a command line shows in ps and the journal)");
  std::map<std::string, std::string> s{{"sslmode", "verify-full"},
                                       {"connect_timeout", "10"},
                                       {"application_name", application_name}};
  if (!password_file.empty()) {
    s["password"] = read_password_file(password_file);
  } else if (const char* env = std::getenv("BRAKEFIT_FLEET_PASSWORD")) {
    s["password"] = env;
  }
  return s;
}

}  // namespace brakefit::cli
