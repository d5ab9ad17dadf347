// `loom run --census`: intersections and max_penetration in summary.json; the `collision` key.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
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

// An OBJ of `triangles` separate triangles (1 mm legs, not flat along any axis) piled within half a
// millimetre: the boxes of every pair of them overlap.
std::string write_pile(const std::string& name, int triangles) {
  const std::string obj = (test_dir() / name).string();
  std::ofstream f(obj);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.0, 0.0005);
  for (int i = 0; i < triangles; ++i) {
    const double x = u(rng), y = u(rng), z = u(rng);
    f << "v " << x << ' ' << y << ' ' << z << "\nv " << x + 0.001 << ' ' << y + 0.001 << ' ' << z << "\nv "
      << x << ' ' << y + 0.001 << ' ' << z + 0.001 << '\n';
  }
  for (int i = 0; i < triangles; ++i) f << "f " << 3 * i + 1 << ' ' << 3 * i + 2 << ' ' << 3 * i + 3 << '\n';
  return obj;
}

// 5000 piled triangles: every pair of them is a census candidate (1.25e7, past
// collision::kCensusCandidateBound). The run stops before frame 0 with the option, the frame and the cloth
// named instead of testing them all (and the summary says it did not complete).
TEST(CensusCli, APiledMeshStopsTheRunWithTheCensusBoundNamed) {
  nlohmann::json j = base_scene();
  j["cloths"] = {{{"name", "heap"},
                  {"mesh", {{"type", "obj"}, {"path", write_pile("pile.obj", 5000)}}},
                  {"material", "cotton"}}};
  const std::string out = (test_dir() / "out").string();
  const auto r = run_loom("run " + write_json_scene("pile.json", j) + " --out " + out + " --census");
  EXPECT_EQ(r.code, 3) << r.err;
  for (const char* part :
       {"--census", "frame 0", "cloth 'heap'", "10000000 candidate triangle pairs", "run without --census"})
    EXPECT_NE(r.err.find(part), std::string::npos) << part << "\n" << r.err;
  const nlohmann::json s = summary_of(out);
  EXPECT_FALSE(s["completed"].get<bool>());
  EXPECT_TRUE(s["finite"].get<bool>());
  EXPECT_NE(s["error"].get<std::string>().find("--census"), std::string::npos);
  // Without --census the same scene runs.
  const auto plain = run_loom("run " + write_json_scene("pile.json", j) + " --out " + out + " --frames 1");
  EXPECT_EQ(plain.code, 0) << plain.err;
}

// Self- and cloth-cloth collision test the triangle pairs that lie close at every step: cloths that start
// piled are refused before the run, in every tier (1500 triangles: 1.1e6 pairs, past the bound of max(1e6,
// 64 per triangle)); 300 piled triangles (45 000 pairs) run. (Two cloths piled onto each other are refused
// earlier, as cloths that start on top of each other.)
TEST(CensusCli, ClothsThatStartPiledAreRefusedWhenCollisionIsOn) {
  const std::string big = write_pile("big.obj", 1500), small = write_pile("small.obj", 300);
  const auto cloth = [](const std::string& name, const std::string& obj) {
    return nlohmann::json{{"name", name}, {"mesh", {{"type", "obj"}, {"path", obj}}}, {"material", "cotton"}};
  };
  const std::string out = (test_dir() / "out").string();
  for (const char* quality : {"reference", "realtime"}) {
    nlohmann::json j = base_scene();
    j.erase("solver");
    j["quality"] = quality;
    j["collision"] = {{"self", true}};
    j["cloths"] = {cloth("heap", big)};
    const auto r = run_loom("run " + write_json_scene("piled.json", j) + " --out " + out + " --frames 1");
    EXPECT_EQ(r.code, 1) << quality << " " << r.err;
    for (const char* part : {"piled.json: collision:", "cloth 'heap'", "start piled onto each other"})
      EXPECT_NE(r.err.find(part), std::string::npos) << part << "\n" << r.err;
    // Self-collision off: within a cloth nothing is tested, so a lone pile runs.
    j["collision"] = {{"self", false}};
    const auto lone = run_loom("run " + write_json_scene("piled.json", j) + " --out " + out + " --frames 1");
    EXPECT_EQ(lone.code, 0) << quality << " " << lone.err;
    // A small pile runs, and without collision a big one does.
    j["cloths"] = {cloth("heap", small)};
    j["collision"] = {{"self", true}};
    const auto ok = run_loom("run " + write_json_scene("piled.json", j) + " --out " + out + " --frames 1");
    EXPECT_EQ(ok.code, 0) << quality << " " << ok.err;
    j.erase("collision");
    j["cloths"] = {cloth("heap", big)};
    const auto off = run_loom("run " + write_json_scene("piled.json", j) + " --out " + out + " --frames 1");
    EXPECT_EQ(off.code, 0) << quality << " " << off.err;
  }
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
