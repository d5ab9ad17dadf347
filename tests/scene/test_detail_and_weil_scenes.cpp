// Scene fields `cloths[i].detail` (hybrid detail) and the refusals of `solver.method: "weil"`,
// each naming the file, the JSON path and the problem; the shipped example scenes load.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "TestDir.h"
#include "loom/cloth/Error.h"
#include "loom/scene/Scene.h"

namespace loom::scene {
namespace {

namespace fs = std::filesystem;

std::string write_scene(const std::string& name, const std::string& text) {
  const fs::path p = test::test_dir() / name;
  std::ofstream(p) << text;
  return p.string();
}

std::string scene_text(const std::string& solver, const std::string& cloth_extra,
                       const std::string& top_extra, double duration = 0.1) {
  return R"({"duration": )" + std::to_string(duration) + R"(, "fps": 60, "solver": )" + solver + R"(,
  "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [1, 1], "nodes": [5, 5]},
              "material": {"preset": "cotton"}, "pins": [{"grid": [0, 0]}, {"grid": [-1, 0]}])" +
         cloth_extra + "}]" + top_extra + "}";
}

std::string error_of(const std::string& name, const std::string& text) {
  const std::string path = write_scene(name, text);
  try {
    Scene s = load_scene(path);
    cloth::Simulation sim(s.setup, path);
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
    return msg;
  }
  return "(no error)";
}

TEST(DetailAndWeilScenes, DetailIsParsed) {
  const std::string path =
      write_scene("detail.json", scene_text(R"({"method": "implicit_euler"})",
                                            R"(, "detail": {"method": "curved_faces", "levels": 3})", ""));
  const Scene s = load_scene(path);
  ASSERT_EQ(s.detail.size(), 1u);
  EXPECT_EQ(s.detail.at(0).levels, 3);
  EXPECT_EQ(s.detail.at(0).method, "curved_faces");
  EXPECT_TRUE(load_scene(write_scene("nodetail.json", scene_text(R"({"method": "implicit_euler"})", "", "")))
                  .detail.empty());
}

TEST(DetailAndWeilScenes, DetailErrorsNameThePath) {
  const std::string solver = R"({"method": "implicit_euler"})";
  std::string m = error_of("levels.json", scene_text(solver, R"(, "detail": {"levels": 9})", ""));
  EXPECT_NE(m.find("cloths[0].detail.levels"), std::string::npos) << m;
  EXPECT_NE(m.find("<= 5"), std::string::npos) << m;
  m = error_of("negative.json", scene_text(solver, R"(, "detail": {"levels": -1})", ""));
  EXPECT_NE(m.find("cloths[0].detail.levels"), std::string::npos) << m;
  m = error_of("method.json", scene_text(solver, R"(, "detail": {"method": "wrinkles"})", ""));
  EXPECT_NE(m.find("cloths[0].detail.method"), std::string::npos) << m;
  m = error_of("key.json", scene_text(solver, R"(, "detail": {"levles": 2})", ""));
  EXPECT_NE(m.find("levles"), std::string::npos) << m;
}

TEST(DetailAndWeilScenes, WrinklesAreParsedAndCheckedByPath) {
  const std::string solver = R"({"method": "implicit_euler"})";
  const Scene s = load_scene(write_scene(
      "wrinkles.json",
      scene_text(solver, R"(, "detail": {"levels": 2, "wrinkles": {"amplitude": 0.004, "wavelength": 0.03}})",
                 "")));
  ASSERT_EQ(s.detail.size(), 1u);
  EXPECT_TRUE(s.detail.at(0).wrinkles.enabled);
  EXPECT_DOUBLE_EQ(s.detail.at(0).wrinkles.amplitude, 0.004);
  EXPECT_DOUBLE_EQ(s.detail.at(0).wrinkles.wavelength, 0.03);
  EXPECT_FALSE(
      load_scene(write_scene("nowrinkles.json", scene_text(solver, R"(, "detail": {"levels": 2})", "")))
          .detail.at(0)
          .wrinkles.enabled);
  std::string m =
      error_of("wl.json", scene_text(solver, R"(, "detail": {"wrinkles": {"wavelength": 0}})", ""));
  EXPECT_NE(m.find("cloths[0].detail.wrinkles.wavelength"), std::string::npos) << m;
  m = error_of("amp.json", scene_text(solver, R"(, "detail": {"wrinkles": {"amplitude": -1}})", ""));
  EXPECT_NE(m.find("cloths[0].detail.wrinkles.amplitude"), std::string::npos) << m;
  m = error_of("wkey.json", scene_text(solver, R"(, "detail": {"wrinkles": {"height": 1}})", ""));
  EXPECT_NE(m.find("height"), std::string::npos) << m;
}

TEST(DetailAndWeilScenes, WeilRefusesWhatNeedsMotionOrCollision) {
  const std::string weil = R"({"method": "weil"})";
  const double one_frame = 1.0 / 60.0;
  // One frame, pins, a grid: accepted.
  EXPECT_EQ(error_of("weil_ok.json", scene_text(weil, "", "", one_frame)), "(no error)");
  std::string m = error_of("weil_duration.json", scene_text(weil, "", "", 1.0));
  EXPECT_NE(m.find("duration"), std::string::npos) << m;
  EXPECT_NE(m.find("weil"), std::string::npos) << m;
  m = error_of(
      "weil_colliders.json",
      scene_text(weil, "", R"(, "colliders": [{"name": "ground", "shape": "plane", "thickness": 0.005}])",
                 one_frame));
  EXPECT_NE(m.find("colliders"), std::string::npos) << m;
  EXPECT_NE(m.find("collision"), std::string::npos) << m;
  m = error_of(
      "weil_wind.json",
      scene_text(weil, "", R"(, "effects": {"drag": {"isotropic": 0.1, "wind": [1, 0, 0]}})", one_frame));
  EXPECT_NE(m.find("effects.drag"), std::string::npos) << m;
  m = error_of("weil_velocity.json", scene_text(weil, R"(, "velocity": [0, 0, 1])", "", one_frame));
  EXPECT_NE(m.find("velocity"), std::string::npos) << m;
  m = error_of("weil_moving.json",
               R"({"duration": 0.0166667, "fps": 60, "solver": {"method": "weil"},
  "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [1, 1], "nodes": [5, 5]},
              "pins": [{"grid": [0, 0], "path": {"times": [0, 1], "offsets": [[0, 0, 0], [0, 1, 0]]}}, {"grid": [-1, 0]}]}]})");
  EXPECT_NE(m.find("pins[0].path"), std::string::npos) << m;
}

TEST(DetailAndWeilScenes, ExampleScenesLoad) {
  for (const char* name : {"hanging_cloth_detail.json", "weil_square.json", "hanging_cloth_imex.json"}) {
    const fs::path p = fs::path(LOOM_SOURCE_DIR) / "scenes" / name;
    Scene s = load_scene(p.string());
    EXPECT_NO_THROW(cloth::Simulation(s.setup, p.string())) << name;
  }
}

}  // namespace
}  // namespace loom::scene
