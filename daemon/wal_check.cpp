#include "daemon/wal_check.hpp"

#include <fmt/format.h>

#include <array>
#include <cstring>
#include <fstream>
#include <vector>

namespace brakefit::daemon {

namespace {

constexpr std::size_t kHeader = 32, kFrameHeader = 24;

std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}
std::uint32_t le32(const unsigned char* p) {
  return (std::uint32_t{p[3]} << 24) | (std::uint32_t{p[2]} << 16) | (std::uint32_t{p[1]} << 8) |
         std::uint32_t{p[0]};
}

/// SQLite's WAL checksum: over 32-bit words in pairs, continuing from (s0, s1).
void checksum(const unsigned char* p, std::size_t n, bool big_endian, std::uint32_t& s0,
              std::uint32_t& s1) {
  for (std::size_t i = 0; i + 8 <= n; i += 8) {
    const std::uint32_t a = big_endian ? be32(p + i) : le32(p + i);
    const std::uint32_t b = big_endian ? be32(p + i + 4) : le32(p + i + 4);
    s0 += a + s1;
    s1 += b + s0;
  }
}

}  // namespace

WalCheck check_wal(const std::string& wal_path) {
  WalCheck w;
  std::ifstream in(wal_path, std::ios::binary);
  if (!in) return w;
  std::vector<unsigned char> b((std::istreambuf_iterator<char>(in)),
                               std::istreambuf_iterator<char>());
  w.bytes = b.size();
  if (b.empty()) return w;
  w.present = true;
  if (b.size() < kHeader) {
    w.problem = fmt::format("{} bytes, shorter than a log's {}-byte header", b.size(), kHeader);
    return w;
  }
  const std::uint32_t magic = be32(b.data());
  const std::uint32_t page = be32(b.data() + 8);
  if ((magic & ~1u) != 0x377f0682u || be32(b.data() + 4) != 3007000u || page < 512 ||
      page > 65536 || (page & (page - 1)) != 0) {
    w.problem = "the header is not a SQLite write-ahead log's";
    return w;
  }
  const bool big = (magic & 1u) != 0;
  std::uint32_t s0 = 0, s1 = 0;
  checksum(b.data(), 24, big, s0, s1);
  if (s0 != be32(b.data() + 24) || s1 != be32(b.data() + 28)) {
    w.problem = "the header fails its checksum";
    return w;
  }
  const std::uint32_t salt1 = be32(b.data() + 16), salt2 = be32(b.data() + 20);
  w.used_bytes = kHeader;
  std::size_t off = kHeader, frame = 0;
  const std::size_t frame_size = kFrameHeader + page;
  while (off < b.size()) {
    ++frame;
    if (b.size() - off < frame_size) {
      w.problem =
          fmt::format("frame {} is cut short ({} of {} bytes)", frame, b.size() - off, frame_size);
      break;
    }
    const unsigned char* f = b.data() + off;
    if (be32(f + 8) != salt1 || be32(f + 12) != salt2) {
      // SQLite adds one to salt-1 each time it starts the log over: an earlier generation's
      // frames carry a smaller one. Anything else was never written by SQLite here.
      const std::uint32_t age = salt1 - be32(f + 8);
      if (age == 0 || age > (1u << 20))
        w.problem = fmt::format("frame {} is neither of this log nor of an earlier one", frame);
      break;
    }
    checksum(f, 8, big, s0, s1);
    checksum(f + kFrameHeader, page, big, s0, s1);
    if (s0 != be32(f + 16) || s1 != be32(f + 20)) {
      w.problem = fmt::format("frame {} fails its checksum", frame);
      break;
    }
    off += frame_size;
    if (be32(f + 4) != 0) {  // a commit frame: the database's size after the transaction
      ++w.commits;
      w.used_bytes = off;
    }
  }
  if (w.problem.empty() && off > w.used_bytes)
    w.problem = fmt::format("{} frame(s) after the last commit belong to no commit",
                            (off - w.used_bytes) / frame_size);
  return w;
}

}  // namespace brakefit::daemon
