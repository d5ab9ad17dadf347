#pragma once
// Hostile input files the tests of several executables build (characters, CLI).
#include <string>

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

}  // namespace loom::test
