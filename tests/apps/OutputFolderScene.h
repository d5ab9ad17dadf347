#pragma once
// The small scene of the output-folder tests (a 5x5 sheet writing OBJ, PC2 and glTF) and its writer.
#include <filesystem>
#include <fstream>
#include <string>

namespace loom::test {

inline const char* kOutputFolderScene = R"({
  "duration": 0.1, "fps": 60,
  "solver": {"method": "symplectic_euler", "substeps": 4},
  "cloths": [{"name": "sheet",
              "mesh": {"type": "grid", "size": [1, 1], "nodes": [5, 5], "origin": [-0.5, 1, -0.5]},
              "material": {"preset": "cotton"}, "mass": 0.2,
              "pins": [{"grid": [0, 0]}, {"grid": [-1, 0]}]}],
  "output": {"formats": ["obj", "pc2", "gltf"]}
})";

// Writes `text` to DIR/scene.json; returns its path.
inline std::string write_scene(const std::filesystem::path& dir,
                               const std::string& text = kOutputFolderScene) {
  const std::filesystem::path p = dir / "scene.json";
  std::ofstream(p) << text;
  return p.string();
}

}  // namespace loom::test
