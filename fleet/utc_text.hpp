#pragma once
// A unix time as UTC text (the fleet's logs, status file, report and COPY rows).
#include <cstdint>
#include <ctime>
#include <string>

namespace brakefit::fleet {

/// strftime of t in UTC, e.g. format "%Y-%m-%d".
inline std::string utc_text(std::int64_t t, const char* format) {
  const auto tt = static_cast<std::time_t>(t);
  std::tm tm{};
  gmtime_r(&tt, &tm);
  char buf[64];
  return std::string(buf, std::strftime(buf, sizeof buf, format, &tm));
}

}  // namespace brakefit::fleet
