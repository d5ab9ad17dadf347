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

// ---- Node graphs and nesting that assimp's readers expand or recurse over ----

namespace loom::test {

// A COLLADA clip whose visual scene's "Hips" instances library node N0, and N<k> instances N<k+1>
// `copies` times for k < `levels` (N<levels> a leaf): 1 + sum of copies^k nodes once expanded. With
// `cycle`, N<levels> instances N0 back (a cycle; levels 0 makes N0 instance itself). Library nodes are
// on lines 4 .. 4 + levels.
inline std::string collada_instances(int levels, int copies, bool cycle = false) {
  std::string text =
      "<?xml version=\"1.0\"?>\n<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" "
      "version=\"1.4.1\">\n<library_nodes>";
  for (int k = 0; k <= levels; ++k) {
    const std::string id = "N" + std::to_string(k);
    text += "\n<node id=\"" + id + "\" name=\"" + id + "\" type=\"JOINT\"><translate>0 1 0</translate>";
    for (int c = 0; k < levels && c < copies; ++c)
      text += "<instance_node url=\"#N" + std::to_string(k + 1) + "\"/>";
    if (k == levels && cycle) text += "<instance_node url=\"#N0\"/>";
    text += "</node>";
  }
  return text +
         "\n</library_nodes><library_visual_scenes><visual_scene id=\"S\"><node id=\"Hips\" name=\"Hips\" "
         "type=\"JOINT\"><instance_node url=\"#N0\"/></node></visual_scene></library_visual_scenes>"
         "<scene><instance_visual_scene url=\"#S\"/></scene></COLLADA>\n";
}

// A glTF whose node 0 ("Hips") has children x0 and y0, where x<k> and y<k> both list x<k+1> and y<k+1>
// as children for k < `levels` (a node with two parents: 2^(levels+2) - 1 nodes once expanded).
inline std::string gltf_two_parents(int levels) {
  std::string nodes = "{\"name\":\"Hips\",\"children\":[1,2]}";
  for (int k = 0; k <= levels; ++k)
    for (const char* axis : {"x", "y"}) {
      nodes += ",{\"name\":\"" + std::string(axis) + std::to_string(k) + "\"";
      if (k < levels)
        nodes += ",\"children\":[" + std::to_string(2 * k + 3) + "," + std::to_string(2 * k + 4) + "]";
      nodes += "}";
    }
  return "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[" + nodes +
         "]}\n";
}

// An ASCII FBX nesting `depth` scopes, one "A: {" per line from line 3; braces inside a string and a
// ';' comment on line 2 do not count.
inline std::string ascii_fbx(int depth) {
  std::string text = "; FBX 7.4.0 project file\n; {{{{ \"\nFBXHeaderExtension: \"{{{{\" {\n";
  for (int k = 1; k < depth; ++k) text += "A: {\n";
  for (int k = 0; k < depth; ++k) text += "}\n";
  return text;
}

// A binary FBX (version 7400: 4-byte words) of `depth` records "A" nested in one another, each but the
// innermost ending with a 13-byte null record, then the top level's null record. With `bad_end`, the
// outermost record's end offset points past the file.
inline std::string binary_fbx(int depth, bool bad_end = false) {
  auto u32 = [](std::string& o, std::uint64_t v) {
    for (int b = 0; b < 4; ++b) o += static_cast<char>((v >> (8 * b)) & 0xff);
  };
  std::string out = std::string("Kaydara FBX Binary  \0\x1a\0", 23);
  u32(out, 7400);
  std::vector<std::uint64_t> size(static_cast<std::size_t>(depth) + 1, 0);  // bytes of record k and inside
  size[static_cast<std::size_t>(depth) - 1] = 14;
  for (int k = depth - 2; k >= 0; --k) size[std::size_t(k)] = 14 + size[std::size_t(k) + 1] + 13;
  for (int k = 0; k < depth; ++k) {
    const std::uint64_t start = out.size();
    u32(out, bad_end && k == 0 ? 0xfffffff0u : start + size[std::size_t(k)]);
    u32(out, 0);
    u32(out, 0);
    out +=
        "\x01"
        "A";
  }
  out += std::string(13 * static_cast<std::size_t>(depth - 1), '\0');  // the nested lists' null records
  return out + std::string(13, '\0') + std::string(16, '\xfa');        // top level's null record, footer
}

}  // namespace loom::test
