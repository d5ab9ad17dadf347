#pragma once
// ObjFile: the one OBJ reader of Loom (cloth meshes, garment meshes and their groups, collider meshes).
// Strict: every line is a known directive whose every token is read, so trailing text (`v 1 2 3 junk`,
// `f 1 2 3x`) is an error, never ignored. Read: `v x y z [w | r g b]`, `vt u v [w]`, `vn x y z`,
// `f a b c ...` with corners v, v/vt, v//vn or v/vt/vn (1-based; negative indices count back from the
// last element defined so far), `g name ...`; `o`, `s`, `usemtl`, `mtllib`, `l` and `vp` are skipped.
// Numbers are decimal (strtod, never hexadecimal) and finite. Errors are loom::Error(path, "line N ('TEXT')",
// problem).
#include <string>
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::cloth {

struct ObjCorner {
  int v = -1;   // 0-based vertex index
  int vt = -1;  // 0-based texture coordinate index, -1: none
};

struct ObjFace {
  std::vector<ObjCorner> corners;  // at least 3
  int group = 0;                   // index into ObjFile::groups: the `g` names in force
  long line = 0;                   // 1-based line number in the file
  std::string text;                // the line as written (for messages: line_where(line, text))
};

struct ObjFile {
  std::string path;
  Vec3s positions;                   // file units
  std::vector<long> position_lines;  // 1-based line of each position
  std::vector<Vec2> texcoords;
  std::vector<ObjFace> faces;
  std::vector<std::vector<std::string>> groups;  // groups[0] = {"default"}; one entry per `g` line after
};

// Reads and checks `path` (a regular file of bounded size, InputFile.h). Throws loom::Error naming the file
// and line. A file without vertices is returned as such (the caller names what it needs).
ObjFile read_obj_file(const std::string& path);

}  // namespace loom::cloth
