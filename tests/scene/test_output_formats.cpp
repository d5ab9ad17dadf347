// `output.formats`: the default, accepted lists, and every bad value named by file, JSON path and problem.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "loom/cloth/Error.h"
#include "loom/scene/Scene.h"

namespace loom::scene {
namespace {

namespace fs = std::filesystem;

const char* kScene = R"({
  "duration": 0.1, "fps": 60,
  "cloths": [{"mesh": {"type": "grid", "size": [1, 1], "nodes": [3, 3]}, "material": "cotton"}]
})";

std::string scene_file() {
  const fs::path dir = fs::temp_directory_path() / "loom_scene_tests";
  fs::create_directories(dir);
  const fs::path p = dir / "output_formats.json";
  std::ofstream(p) << kScene;
  return p.string();
}

TEST(OutputFormats, DefaultIsObjAndListsAreKeptInOrder) {
  const std::string path = scene_file();
  EXPECT_EQ(load_scene(path).output.formats, std::vector<std::string>{"obj"});
  EXPECT_EQ(load_scene(path, {"output.formats=[\"gltf\", \"pc2\"]"}).output.formats,
            (std::vector<std::string>{"gltf", "pc2"}));
  EXPECT_TRUE(load_scene(path, {"output.formats=[]"}).output.formats.empty());
}

TEST(OutputFormats, BadValuesNameFilePathAndProblem) {
  const std::string path = scene_file();
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"output.formats=\"gltf\"", "output.formats", "expected an array of format names"},
      {"output.formats=[\"obj\", \"fbx\"]", "output.formats[1]", "unknown format 'fbx'"},
      {"output.formats=[\"pc2\", 3]", "output.formats[1]", "expected a format name"},
      {"output.formats=[\"gltf\", \"gltf\"]", "output.formats[1]", "listed twice"},
  };
  for (const auto& [set, where, problem] : cases) {
    std::string msg = "(no error)";
    try {
      load_scene(path, {set});
    } catch (const Error& e) {
      msg = e.what();
    }
    EXPECT_EQ(msg.rfind(path + ": " + where + ": ", 0), 0u) << set << " -> " << msg;
    EXPECT_NE(msg.find(problem), std::string::npos) << set << " -> " << msg;
  }
}

}  // namespace
}  // namespace loom::scene
