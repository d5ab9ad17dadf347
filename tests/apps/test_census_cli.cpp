// `loom run --census`: intersections and max_penetration in summary.json; the `collision` key.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "CliRunner.h"

namespace {

using loom::test::run_loom;
using loom::test::test_dir;
using loom::test::write_json_scene;

nlohmann::json sheet(const std::string& name, const std::string& plane, const std::vector<double>& origin) {
  return {{"name", name},
          {"mesh",
           {{"type", "grid"}, {"size", {0.4, 0.4}}, {"nodes", {9, 9}}, {"plane", plane}, {"origin", origin}}},
          {"material", "cotton"}};
}

nlohmann::json base_scene() {
  return {{"name", "census"},
          {"duration", 0.05},
          {"fps", 60},
          {"gravity", {0, 0, 0}},
          {"solver", {{"method", "implicit_euler"}, {"substeps", 1}}},
          {"output", {{"frames", false}}}};
}

using loom::test::summary_of;

// Two sheets crossing each other (no collision handling): the census counts their intersecting pairs.
TEST(CensusCli, CountsCrossingSheets) {
  nlohmann::json j = base_scene();
  j["cloths"] = {sheet("flat", "xz", {-0.2, 0.5, -0.2}), sheet("upright", "xy", {-0.2, 0.3, 0.0})};
  const std::string scene = write_json_scene("crossing.json", j), out = (test_dir() / "out").string();
  const auto r = run_loom("run " + scene + " --out " + out + " --frames 2 --census");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json s = summary_of(out);
  ASSERT_TRUE(s.contains("intersections"));
  EXPECT_GT(s["intersections"].get<long>(), 0);
  EXPECT_EQ(s["max_penetration"].get<double>(), 0.0);  // no colliders
  // Without --census the keys are absent.
  const auto r2 = run_loom("run " + scene + " --out " + out + " --frames 1");
  ASSERT_EQ(r2.code, 0) << r2.err;
  EXPECT_FALSE(summary_of(out).contains("intersections"));
}

// Two sheets thrown into each other at 3 m/s with `collision`: the stage runs (its counters are in the
// summary) and the census stays at 0.
TEST(CensusCli, CollisionKeepsLayersApart) {
  nlohmann::json j = base_scene();
  nlohmann::json top = sheet("top", "xz", {-0.2, 0.51, -0.2});
  top["velocity"] = {0.0, -3.0, 0.0};
  j["cloths"] = {sheet("bottom", "xz", {-0.2, 0.5, -0.2}), top};
  j["collision"] = {{"self", true}, {"layers", {0.002, 0.001}}, {"passes", 3}};
  const std::string scene = write_json_scene("layers.json", j), out = (test_dir() / "out").string();
  const auto r = run_loom("run " + scene + " --out " + out + " --census --threads 2");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json s = summary_of(out);
  EXPECT_EQ(s["intersections"].get<long>(), 0);
  ASSERT_TRUE(s["counters"].contains("self_collision")) << s.dump();
  EXPECT_GT(s["counters"]["self_collision"]["contacts"].get<double>(), 0.0);
  EXPECT_TRUE(s["finite"].get<bool>());
}

TEST(CensusCli, CollisionKeyErrorsNameThePath) {
  nlohmann::json j = base_scene();
  j["cloths"] = {sheet("a", "xz", {-0.2, 0.5, -0.2}), sheet("b", "xz", {-0.2, 0.6, -0.2})};
  j["collision"] = {{"layers", {0.002}}};
  const auto r =
      run_loom("run " + write_json_scene("bad.json", j) + " --out " + (test_dir() / "out").string());
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("collision.layers"), std::string::npos) << r.err;
  j["collision"] = {{"passes", 2}, {"bogus", 1}};
  const auto r2 =
      run_loom("run " + write_json_scene("bad2.json", j) + " --out " + (test_dir() / "out").string());
  EXPECT_EQ(r2.code, 1);
  EXPECT_NE(r2.err.find("collision.bogus"), std::string::npos) << r2.err;
}

}  // namespace
