// `output.formats` and `output.render`: defaults, accepted values, and every bad value named by file, JSON
// path and problem.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "TestDir.h"
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
  const fs::path p = test::test_dir() / "output_formats.json";
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

TEST(OutputRender, DefaultsAndCamera) {
  const std::string path = scene_file();
  const RenderOutput d = load_scene(path).output.render;
  EXPECT_EQ(d.width, 640);
  EXPECT_EQ(d.height, 480);
  EXPECT_FALSE(d.camera);
  const RenderOutput c = load_scene(path, {"output.render={\"width\": 320, \"every\": 2, \"camera\": "
                                           "{\"eye\": [1, 2, 3], \"target\": [0, 1, 0]}}"})
                             .output.render;
  EXPECT_EQ(c.width, 320);
  EXPECT_EQ(c.every, 2);
  EXPECT_TRUE(c.camera);
  EXPECT_EQ(c.eye, cloth::Vec3(1, 2, 3));
  EXPECT_EQ(c.fov, 40.0);
}

TEST(OutputFormats, BadValuesNameFilePathAndProblem) {
  const std::string path = scene_file();
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"output.formats=\"gltf\"", "output.formats", "expected an array of format names"},
      {"output.formats=[\"obj\", \"fbx\"]", "output.formats[1]", "unknown format 'fbx'"},
      {"output.formats=[\"pc2\", 3]", "output.formats[1]", "expected a format name"},
      {"output.formats=[\"gltf\", \"gltf\"]", "output.formats[1]", "listed twice"},
      {"output.render={\"width\": 8}", "output.render.width", "must be >= 16"},
      {"output.render={\"height\": 9000}", "output.render.height", "must be <= 8192"},
      {"output.render={\"every\": 0}", "output.render.every", "must be >= 1"},
      {"output.render={\"size\": 3}", "output.render.size", "unknown key"},
      {"output.render={\"camera\": {\"eye\": [0, 1, 3], \"target\": [0, 1, 0], \"fov\": 175}}",
       "output.render.camera.fov", "must be < 170"},
      {"output.render={\"camera\": {\"eye\": [0, 1, 3], \"target\": [0, 1, 3]}}",
       "output.render.camera.target", "must differ"},
      {"output.render={\"camera\": {\"eye\": [0, 1]}}", "output.render.camera.eye", "expected 3 numbers"},
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
