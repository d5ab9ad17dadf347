// A run the guard stops (exit 3) names, beside the frame and the cause, the scene's fields that put it
// outside the validated regime (SceneRegime.h): legal values whose combination a frame's steps cannot
// carry. The message and summary.json's "error" name the file and the field; no output holds a NaN.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "CliRunner.h"

namespace loom::test {
namespace {

namespace fs = std::filesystem;

const char* kSheet = R"({
  "name": "sheet", "duration": 0.1, "fps": 60,
  "solver": {"method": "symplectic_euler", "substeps": 8},
  "cloths": [{"name": "sheet",
              "mesh": {"type": "grid", "size": [1, 1], "nodes": [5, 5], "origin": [0, 1.5, 0]},
              "material": {"preset": "cotton"}, "mass": 0.2,
              "pins": [{"grid": [0, 0]}, {"grid": [-1, 0]}]}],
  "output": {"formats": ["obj", "pc2"]}
})";

struct Extreme {
  const char* set;    // --set of a legal but extreme combination
  const char* more;   // a second --set, or ""
  const char* field;  // the field the message names
};

TEST(DivergenceCli, AnExtremeButLegalSceneStopsNamingTheFieldsOutsideTheRegime) {
  const std::string scene = write_json_scene("sheet.json", nlohmann::json::parse(kSheet));
  const Extreme cases[] = {
      {"gravity=[1e4,1e4,1e4]", "cloths[0].mesh.nodes=[17,17]", "gravity (|g| = 1.73e+04 m/s^2"},
      {"cloths[0].material={\"preset\":\"cotton\",\"stretch\":1e12}", "", "cloths[0].material stretch"},
      {"effects={\"drag\":{\"isotropic\":1e12,\"wind\":[1e4,0,0]}}", "", "effects.drag.wind"},
      {"cloths[0].velocity=[0,1000,0]", "", "cloths[0].velocity (1e+03 m/s"},
  };
  int k = 0;
  for (const Extreme& c : cases) {
    SCOPED_TRACE(c.set);
    const fs::path out = test_dir() / ("out" + std::to_string(k++));
    const auto r = run_loom("run " + scene + " --out " + out.string() + " --set '" + c.set + "'" +
                            (*c.more ? std::string(" --set '") + c.more + "'" : std::string()));
    ASSERT_EQ(r.code, 3) << r.err;
    EXPECT_NE(r.err.find("sheet.json: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("outside the validated regime: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.field), std::string::npos) << r.err;
    const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
    EXPECT_EQ(j["completed"], false);
    EXPECT_NE(j["error"].get<std::string>().find(c.field), std::string::npos) << j.dump(1);
    const std::string stats = slurp(out / "stats.csv");
    EXPECT_FALSE(stats.empty());
    for (const char* bad : {"nan", "inf"}) EXPECT_EQ(stats.find(bad), std::string::npos) << stats;
  }
}

// Inside the regime, the message names the fields that give a frame more steps and the guard's own bound.
TEST(DivergenceCli, AStopInsideTheRegimeNamesTheGuardBoundAndTheStepFields) {
  const std::string scene = write_json_scene("sheet.json", nlohmann::json::parse(kSheet));
  const auto r = run_loom("run " + scene + " --out " + (test_dir() / "out").string() +
                          " --set guard.max_strain=0.001 --set guard.max_halvings=1");
  ASSERT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("limit guard.max_strain 0.001"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("more solver.substeps (now 8 per frame) or a larger guard.max_halvings"),
            std::string::npos)
      << r.err;
}

// The bundled sphere scene with a box in place of the sphere (reference tier, self-collision on): the sheet
// lands on the box and drapes over its edges; every frame is written, finite, and no edge is stretched to
// twice its length (a cloth edge cutting the box is pushed out the shortest way, not across the box).
TEST(DivergenceCli, ASheetDrapedOverABoxFinishesEveryFrame) {
  const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/sphere_spin.json";
  const fs::path out = test_dir() / "out";
  const auto r =
      run_loom("run " + scene + " --frames 24 --out " + out.string() +
               " --set 'colliders[0]={\"name\":\"b\",\"shape\":\"box\",\"half_extents\":[0.3,0.1,0.3],"
               "\"position\":[0,0.5,0]}'");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(j["completed"], true);
  EXPECT_EQ(j["frames"], 24);
  const std::string stats = slurp(out / "stats.csv");
  std::istringstream in(stats);
  std::string line;
  std::getline(in, line);
  int rows = 0;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::istringstream cs(line);
    for (std::string cell; std::getline(cs, cell, ',');) cells.push_back(cell);
    ASSERT_GT(cells.size(), 5u) << line;
    EXPECT_LT(std::stod(cells[5]), 1.0) << "max_strain, frame " << cells[0];
    ++rows;
  }
  EXPECT_EQ(rows, 25);
}

}  // namespace
}  // namespace loom::test
