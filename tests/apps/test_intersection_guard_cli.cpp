// `loom run` and the guard's intersection check (`guard.intersections`): on by default for a scene
// with cloth collision. A pinned vertex of one sheet is driven (pin path) up through another sheet whose
// every vertex is pinned: no collision stage can move kinematic vertices, so the sheets must intersect. The
// guard must stop the run with exit 3 naming the cause and the last valid frame; with `guard.intersections`
// false the run goes on and the census finds the pairs; a start that is already tangled is allowed.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "CliRunner.h"

namespace {

using loom::test::run_loom;
using loom::test::test_dir;
using loom::test::write_json_scene;

using loom::test::summary_of;

// The middle vertex (of 5x5) of "lower" at y = 0 goes up by 0.1 m over 0.1 s (6 frames), through "upper"
// (3x3, every vertex pinned) at y = 0.05.
nlohmann::json pierce_scene() {
  nlohmann::json upper_pins = nlohmann::json::array();
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) upper_pins.push_back({{"grid", {i, k}}});
  return {{"name", "pierce"},
          {"duration", 0.15},
          {"fps", 60},
          {"gravity", {0, 0, 0}},
          {"solver", {{"method", "implicit_euler"}, {"substeps", 2}}},
          {"guard", {{"max_halvings", 1}}},
          {"collision", {{"self", true}}},
          {"output", {{"frames", true}}},
          {"cloths",
           {{{"name", "lower"},
             {"mesh",
              {{"type", "grid"},
               {"size", {0.4, 0.4}},
               {"nodes", {5, 5}},
               {"plane", "xz"},
               {"origin", {-0.2, 0.0, -0.2}}}},
             {"material", "cotton"},
             {"pins",
              {{{"vertex", 12}, {"path", {{"times", {0, 0.1}}, {"offsets", {{0, 0, 0}, {0, 0.1, 0}}}}}}}}},
            {{"name", "upper"},
             {"mesh",
              {{"type", "grid"},
               {"size", {0.3, 0.3}},
               {"nodes", {3, 3}},
               {"plane", "xz"},
               {"origin", {-0.13, 0.05, -0.17}}}},
             {"material", "cotton"},
             {"pins", upper_pins}}}}};
}

TEST(IntersectionGuardCli, OnByDefaultWithCollisionAndStopsNamingTheCause) {
  const std::string scene = write_json_scene("pierce.json", pierce_scene()),
                    out = (test_dir() / "out").string();
  const auto r = run_loom("run " + scene + " --out " + out);
  ASSERT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("pierce.json: cloth intersections: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(" of cloth 'lower' and triangle "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(" of cloth 'upper')"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("also with 4 substeps; stopped, frames up to "), std::string::npos) << r.err;
  const nlohmann::json s = summary_of(out);
  EXPECT_FALSE(s["completed"].get<bool>());
  EXPECT_FALSE(
      s["finite"].get<bool>());  // as every guard stop: the run did not end on a good frame it was asked for
  const int valid = s["frames"].get<int>();
  EXPECT_GE(valid, 1);
  EXPECT_LT(valid, 6);  // the vertex reaches the upper sheet (0.05 m) at frame 3
  EXPECT_NE(r.err.find("frames up to " + std::to_string(valid) + " are valid"), std::string::npos) << r.err;
  // The valid frames are written, the failed one is not.
  char name[32];
  std::snprintf(name, sizeof name, "frames/frame_%05d.obj", valid);
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(out) / name)) << name;
  std::snprintf(name, sizeof name, "frames/frame_%05d.obj", valid + 1);
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::path(out) / name)) << name;
  ASSERT_TRUE(s["counters"].contains("intersection_guard")) << s.dump();
  EXPECT_GT(s["counters"]["intersection_guard"]["violations"].get<double>(), 0.0);
}

TEST(IntersectionGuardCli, OffInTheSceneTheRunGoesOnAndTheCensusFindsThePairs) {
  nlohmann::json j = pierce_scene();
  j["guard"]["intersections"] = false;
  const std::string scene = write_json_scene("pierce_off.json", j), out = (test_dir() / "out").string();
  const auto r = run_loom("run " + scene + " --out " + out + " --census");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json s = summary_of(out);
  EXPECT_GT(s["intersections"].get<long>(), 0);
  EXPECT_FALSE(s["counters"].contains("intersection_guard")) << s.dump();
  // --set turns it on again.
  const auto r2 = run_loom("run " + scene + " --out " + out + " --set guard.intersections=true");
  EXPECT_EQ(r2.code, 3) << r2.err;
}

TEST(IntersectionGuardCli, ATangledStartIsAllowed) {
  // "upper" stands upright through "lower" from the start (plane xy at z = 0.01, y from -0.1 to 0.2); nothing
  // moves (no gravity, no pin path): the pairs of the start are allowed, the run completes.
  nlohmann::json j = pierce_scene();
  j["cloths"][0].erase("pins");
  j["cloths"][1]["mesh"]["plane"] = "xy";
  j["cloths"][1]["mesh"]["origin"] = {-0.13, -0.1, 0.01};
  const std::string scene = write_json_scene("tangled.json", j), out = (test_dir() / "out").string();
  const auto r = run_loom("run " + scene + " --out " + out + " --census");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json s = summary_of(out);
  EXPECT_GT(s["intersections"].get<long>(), 0);
  EXPECT_EQ(s["counters"]["intersection_guard"]["violations"].get<double>(), 0.0);
}

}  // namespace
