#include "drivers/candump_file.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/curve.hpp"

namespace brakefit::drivers {

can::CandumpText read_candump_file(const std::string& path, bool lenient) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  std::ostringstream ss;
  ss << in.rdbuf();
  return can::parse_candump_text(ss.str(), path, lenient);
}

void write_candump_file(const std::string& path, const std::vector<can::LoggedFrame>& frames) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(fmt::format("{}: cannot write: {}", path, std::strerror(errno)));
    std::string buf;
    buf.reserve(frames.size() * 48);
    for (const auto& f : frames) {
      buf += can::format_candump_line(f);
      buf += '\n';
    }
    out << buf;
    if (!out.flush()) throw InputError(fmt::format("{}: write failed", path));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw InputError(fmt::format("{}: cannot rename into place: {}", path, std::strerror(errno)));
}

}  // namespace brakefit::drivers
