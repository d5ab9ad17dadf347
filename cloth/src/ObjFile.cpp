#include "loom/cloth/ObjFile.h"

#include <cerrno>
#include <cstdlib>
#include <sstream>

#include "loom/cloth/Error.h"
#include "loom/cloth/InputFile.h"

namespace loom::cloth {

namespace {

// One decimal number read with strtod, so that "nan" and "inf" are read and then rejected by name; never
// hexadecimal ("0x1p3"), which strtod would also read.
bool decimal(const std::string& tok, double& out) {
  if (tok.find_first_of("xX") != std::string::npos) return false;
  char* end = nullptr;
  out = std::strtod(tok.c_str(), &end);
  return end != tok.c_str() && end == tok.c_str() + tok.size();  // the whole token (a NUL inside is text)
}

// A whole-token decimal integer (sign allowed), nothing after it; false past the range of long.
bool integer(const std::string& tok, long& out) {
  if (tok.empty()) return false;
  char* end = nullptr;
  errno = 0;
  out = std::strtol(tok.c_str(), &end, 10);
  return end != tok.c_str() && end == tok.c_str() + tok.size() && errno != ERANGE;
}

}  // namespace

ObjFile read_obj_file(const std::string& path) {
  const std::string file = read_input_file(path);
  ObjFile obj;
  obj.path = path;
  obj.groups.push_back({"default"});
  long normals = 0;
  long line_no = 0;
  std::string line;
  auto fail = [&](const std::string& problem) { throw Error(path, line_where(line_no, line), problem); };
  for_each_input_line(file, [&](const std::string& text) {
    line = text;
    ++line_no;
    std::istringstream ls(line);
    std::string tag;
    if (!(ls >> tag) || tag[0] == '#') return;
    auto read_numbers = [&](int count, double* out) {
      std::string tok;
      for (int k = 0; k < count; ++k)
        if (!(ls >> tok) || !decimal(tok, out[k])) return false;
      return true;
    };
    // After the numbers a directive needs, only numbers may follow (a `v`'s weight or the common r g b
    // colour extension, a `vt`'s w): never text.
    auto only_numbers = [&](const char* what) {
      std::string tok;
      double extra = 0.0;
      while (ls >> tok)
        if (!decimal(tok, extra)) fail("unexpected '" + tok + "' after the " + what);
    };
    if (tag == "v") {
      Vec3 p;
      if (!read_numbers(3, p.data())) fail("'v' needs three numbers (decimal)");
      only_numbers("vertex's coordinates");
      if (!p.allFinite()) fail("vertex coordinate is not finite");
      obj.positions.push_back(p);
      obj.position_lines.push_back(line_no);
    } else if (tag == "vt") {
      Vec2 uv;
      if (!read_numbers(2, uv.data())) fail("'vt' needs two numbers (decimal)");
      only_numbers("texture coordinates");
      if (!uv.allFinite()) fail("texture coordinate is not finite");
      obj.texcoords.push_back(uv);
    } else if (tag == "vn") {
      Vec3 n;
      if (!read_numbers(3, n.data())) fail("'vn' needs three numbers (decimal)");
      std::string tok;
      if (ls >> tok) fail("unexpected '" + tok + "' after the normal");
      if (!n.allFinite()) fail("normal is not finite");
      ++normals;
    } else if (tag == "f") {
      ObjFace face;
      face.group = static_cast<int>(obj.groups.size()) - 1;
      face.line = line_no;
      face.text = line.substr(0, kQuotedChars + 1);  // what line_where quotes
      std::string corner;
      // 1-based index, or negative counting back from the end; 0 and beyond `count` are refused.
      auto parse_index = [&](const std::string& s, long count, const char* what) {
        long idx = 0;
        if (!integer(s, idx)) fail(std::string("bad ") + what + " index '" + s + "'");
        const long resolved = idx > 0 ? idx - 1 : count + idx;
        if (idx == 0 || resolved < 0 || resolved >= count)
          fail(std::string(what) + " index " + s + " is out of range (" + std::to_string(count) +
               " defined so far)");
        return static_cast<int>(resolved);
      };
      while (ls >> corner) {
        // v, v/vt, v//vn or v/vt/vn: at most two slashes.
        const size_t slash = corner.find('/');
        const size_t slash2 = slash == std::string::npos ? slash : corner.find('/', slash + 1);
        if (slash2 != std::string::npos && corner.find('/', slash2 + 1) != std::string::npos)
          fail("bad vertex index '" + corner + "' (a corner is v, v/vt, v//vn or v/vt/vn)");
        ObjCorner c;
        c.v = parse_index(corner.substr(0, slash), static_cast<long>(obj.positions.size()), "vertex");
        if (slash != std::string::npos) {
          const std::string vt =
              corner.substr(slash + 1, slash2 == std::string::npos ? std::string::npos : slash2 - slash - 1);
          if (!vt.empty()) c.vt = parse_index(vt, static_cast<long>(obj.texcoords.size()), "texture");
          if (slash2 != std::string::npos)
            parse_index(corner.substr(slash2 + 1), normals, "normal");
          else if (vt.empty())
            fail("bad texture index '' in '" + corner + "'");
        }
        face.corners.push_back(c);
      }
      if (face.corners.size() < 3) fail("a face needs at least 3 vertices");
      obj.faces.push_back(std::move(face));
    } else if (tag == "g") {
      std::vector<std::string> names;
      std::string name;
      while (ls >> name) names.push_back(name);
      if (names.empty()) names.push_back("default");
      obj.groups.push_back(std::move(names));
    } else if (tag == "o" || tag == "s" || tag == "usemtl" || tag == "mtllib" || tag == "l" || tag == "vp") {
      return;
    } else {
      fail("unknown OBJ directive '" + tag + "'");
    }
  });
  return obj;
}

}  // namespace loom::cloth
