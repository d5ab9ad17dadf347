#pragma once
// Hostile input files the tests of several executables build (characters, CLI).
#include <zlib.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace loom::test {

// A COLLADA document whose visual scene nests `depth` <node> elements, one per line from line 2.
inline std::string deep_collada(int depth) {
  std::string text =
      "<?xml version=\"1.0\"?>\n<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" "
      "version=\"1.4.1\"><library_visual_scenes><visual_scene id=\"S\">";
  for (int k = 0; k < depth; ++k) text += "\n<node>";
  for (int k = 0; k < depth; ++k) text += "</node>";
  return text +
         "</visual_scene></library_visual_scenes><scene><instance_visual_scene url=\"#S\"/></scene>"
         "</COLLADA>\n";
}

// A zip archive (PKWARE APPNOTE 6.3: local headers, central directory, end record) holding `files`, stored
// (method 0) or, with `deflated`, compressed (method 8, raw deflate through zlib); `claimed` (if not 0) is
// the unpacked size the central directory gives for each entry.
inline std::string zip(const std::vector<std::pair<std::string, std::string>>& files,
                       std::uint32_t claimed = 0, bool deflated = false) {
  auto crc32 = [](const std::string& s) {
    std::uint32_t c = 0xffffffffu;
    for (unsigned char b : s) {
      c ^= b;
      for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return ~c;
  };
  auto u16 = [](std::string& o, std::uint32_t v) { o += {char(v & 0xff), char((v >> 8) & 0xff)}; };
  auto u32 = [&](std::string& o, std::uint32_t v) {
    u16(o, v & 0xffff);
    u16(o, v >> 16);
  };
  std::string out, dir;
  for (const auto& [name, data] : files) {
    const std::uint32_t offset = static_cast<std::uint32_t>(out.size()), crc = crc32(data);
    const std::uint32_t size = static_cast<std::uint32_t>(data.size());
    std::string packed = data;
    if (deflated) {
      z_stream z{};
      deflateInit2(&z, 9, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
      packed.resize(deflateBound(&z, size));
      z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
      z.avail_in = size;
      z.next_out = reinterpret_cast<Bytef*>(packed.data());
      z.avail_out = static_cast<uInt>(packed.size());
      deflate(&z, Z_FINISH);
      packed.resize(z.total_out);
      deflateEnd(&z);
    }
    const std::uint32_t method = deflated ? 8u : 0u, stored = static_cast<std::uint32_t>(packed.size());
    out += "PK\x03\x04";
    for (std::uint32_t v : {20u, 0u, method, 0u, 0u}) u16(out, v);  // version, flags, method, time, date
    u32(out, crc);
    u32(out, stored);
    u32(out, size);
    u16(out, static_cast<std::uint32_t>(name.size()));
    u16(out, 0);
    out += name + packed;
    dir += "PK\x01\x02";
    for (std::uint32_t v : {20u, 20u, 0u, method, 0u, 0u}) u16(dir, v);
    u32(dir, crc);
    u32(dir, stored);
    u32(dir, claimed ? claimed : size);
    u16(dir, static_cast<std::uint32_t>(name.size()));
    for (std::uint32_t v : {0u, 0u, 0u, 0u}) u16(dir, v);
    u32(dir, 0);
    u32(dir, offset);
    dir += name;
  }
  const std::uint32_t at = static_cast<std::uint32_t>(out.size());
  out += dir + "PK\x05\x06";
  for (std::uint32_t v : {0u, 0u}) u16(out, v);
  u16(out, static_cast<std::uint32_t>(files.size()));
  u16(out, static_cast<std::uint32_t>(files.size()));
  u32(out, static_cast<std::uint32_t>(dir.size()));
  u32(out, at);
  u16(out, 0);
  return out;
}

}  // namespace loom::test
