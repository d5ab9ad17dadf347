// Scene colliders: the `colliders` key's error paths and motion sampling. The stress scenes with
// colliders (sphere_spin, funnel, capsule_shot, tablecloth_pull, layer_stack) run in
// test_collision_scenes.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "loom/cloth/Error.h"
#include "loom/collision/ColliderDistance.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace loom::scene {
namespace {

nlohmann::json base_scene() {
  return nlohmann::json::parse(
      R"({"cloths": [{"mesh": {"type": "grid", "size": [1, 1], "nodes": [3, 3]}}]})");
}

std::string error_of(const nlohmann::json& colliders) {
  nlohmann::json root = base_scene();
  root["colliders"] = colliders;
  try {
    parse_scene(root, "scene.json");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(SceneColliders, ErrorsNameFilePathAndProblem) {
  using nlohmann::json;
  auto has = [](const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; };
  auto err = [&](const char* text) { return error_of(json::parse(text)); };
  std::string e = err(R"([{"shape": "cone"}])");
  EXPECT_TRUE(has(e, "scene.json") && has(e, "colliders[0].shape")) << e;
  e = err(R"([{"shape": "sphere", "radius": -1}])");
  EXPECT_TRUE(has(e, "colliders[0].radius")) << e;
  e = err(R"([{"shape": "box", "half_extents": [1, 0, 1]}])");
  EXPECT_TRUE(has(e, "colliders[0].half_extents")) << e;
  e = err(R"([{"shape": "sphere", "radius": 1, "friction": 0.5, "static_friction": 0.2}])");
  EXPECT_TRUE(has(e, "colliders[0].static_friction")) << e;
  e = err(R"([{"shape": "convex", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]]}])");
  EXPECT_TRUE(has(e, "colliders[0]") && has(e, "4 vertices")) << e;
  e = err(R"([{"shape": "mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "triangles": [[0, 1, 5]]}])");
  EXPECT_TRUE(has(e, "colliders[0].triangles[0][2]") && has(e, "must be <= 2 (got 5)")) << e;
  e = err(R"([{"shape": "mesh", "obj": "missing.obj"}])");
  EXPECT_TRUE(has(e, "colliders[0].obj") && has(e, "no such file")) << e;
  e = err(R"([{"shape": "sphere", "radius": 1, "motion": {"spin": {"axis": [0, 0, 0], "rate": 1}}}])");
  EXPECT_TRUE(has(e, "colliders[0].motion.spin.axis")) << e;
  e = err(R"([{"shape": "sphere", "radius": 1, "motion": {"keyframes": [{"t": 1}, {"t": 0.5}]}}])");
  EXPECT_TRUE(has(e, "keyframes[1].t")) << e;
  e = err(R"([{"shape": "sphere", "radius": 1, "colour": "red"}])");
  EXPECT_TRUE(has(e, "colliders[0].colour")) << e;
}

// collision.friction_pairs: names resolve to cloth / collider indices; bad names and static < kinetic are
// errors naming the file and the JSON path.
TEST(SceneColliders, FrictionPairsResolveNamesAndReportErrors) {
  auto scene_with = [](const char* pairs) {
    nlohmann::json root = nlohmann::json::parse(R"({"cloths": [
        {"name": "shirt", "mesh": {"type": "grid", "size": [1, 1], "nodes": [3, 3]}},
        {"name": "coat", "mesh": {"type": "grid", "size": [1, 1], "nodes": [3, 3], "origin": [0, 0.01, 0]}}],
      "colliders": [{"name": "ball", "shape": "sphere", "radius": 0.1}, {"name": "floor", "shape": "plane"}]})");
    root["collision"] = {{"self", true}, {"friction_pairs", nlohmann::json::parse(pairs)}};
    return root;
  };
  const Scene s =
      parse_scene(scene_with(R"([{"a": "coat", "b": "shirt", "friction": 0.2, "static_friction": 0.3},
                                             {"a": "shirt", "b": "floor", "friction": 0.6}])"),
                  "scene.json");
  ASSERT_TRUE(s.collision.has_value());
  ASSERT_EQ(s.collision->friction_pairs.size(), 2u);
  const auto& p0 = s.collision->friction_pairs[0];
  EXPECT_EQ(p0.cloth, 1);
  EXPECT_EQ(p0.other_cloth, 0);
  EXPECT_EQ(p0.collider, -1);
  EXPECT_DOUBLE_EQ(p0.static_friction, 0.3);
  const auto& p1 = s.collision->friction_pairs[1];
  EXPECT_EQ(p1.cloth, 0);
  EXPECT_EQ(p1.other_cloth, -1);
  EXPECT_EQ(p1.collider, 1);
  EXPECT_DOUBLE_EQ(p1.static_friction, 0.6);  // defaults to the kinetic one
  auto err = [&](const char* pairs) {
    try {
      parse_scene(scene_with(pairs), "scene.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  auto has = [](const std::string& e, const std::string& part) { return e.find(part) != std::string::npos; };
  std::string e = err(R"([{"a": "ball", "b": "shirt", "friction": 0.2}])");
  EXPECT_TRUE(has(e, "scene.json") && has(e, "collision.friction_pairs[0].a") && has(e, "no cloth")) << e;
  e = err(R"([{"a": "shirt", "b": "coat", "friction": 0.2}, {"a": "shirt", "b": "table", "friction": 0.2}])");
  EXPECT_TRUE(has(e, "collision.friction_pairs[1].b") && has(e, "table")) << e;
  e = err(R"([{"a": "shirt", "b": "coat", "friction": 0.4, "static_friction": 0.3}])");
  EXPECT_TRUE(has(e, "collision.friction_pairs[0].static_friction")) << e;
  e = err(R"([{"a": "shirt", "b": "coat"}])");
  EXPECT_TRUE(has(e, "collision.friction_pairs[0].friction")) << e;
}

// A friction pair's name that stands for two cloths, or for a cloth and a collider, is refused by field:
// which of them the pair would bind is not something the user can see.
TEST(SceneColliders, FrictionPairsRefuseNamesThatStandForTwoObjects) {
  auto err = [](const char* cloth_names, const char* pairs) {
    nlohmann::json root = nlohmann::json::parse(R"({"cloths": [
        {"mesh": {"type": "grid", "size": [1, 1], "nodes": [3, 3]}},
        {"mesh": {"type": "grid", "size": [1, 1], "nodes": [3, 3], "origin": [0, 0.5, 0]}}],
      "colliders": [{"name": "ball", "shape": "sphere", "radius": 0.1, "position": [5, 0, 0]}]})");
    const nlohmann::json names = nlohmann::json::parse(cloth_names);
    root["cloths"][0]["name"] = names[0];
    root["cloths"][1]["name"] = names[1];
    root["collision"] = {{"self", true}, {"friction_pairs", nlohmann::json::parse(pairs)}};
    try {
      parse_scene(root, "scene.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  auto has = [](const std::string& e, const std::string& part) { return e.find(part) != std::string::npos; };
  std::string e = err(R"(["a", "a"])", R"([{"a": "a", "b": "a", "friction": 0.9}])");
  EXPECT_TRUE(has(e, "scene.json") && has(e, "collision.friction_pairs[0].a") &&
              has(e, "cloths[0] and cloths[1]"))
      << e;
  e = err(R"(["a", "ball"])", R"([{"a": "a", "b": "ball", "friction": 0.9}])");
  EXPECT_TRUE(has(e, "collision.friction_pairs[0].b") && has(e, "cloths[1] and colliders[0]")) << e;
  EXPECT_EQ(err(R"(["a", "b"])", R"([{"a": "a", "b": "b", "friction": 0.9}])"), "");
  // Two cloths of one name are fine while no pair names them.
  EXPECT_EQ(err(R"(["a", "a"])", "[]"), "");
}

TEST(SceneColliders, MotionSamplesKeyframesAndSpin) {
  nlohmann::json root = base_scene();
  root["colliders"] = nlohmann::json::parse(R"([
    {"shape": "box", "half_extents": [1, 1, 1],
     "motion": {"keyframes": [{"t": 0, "position": [0, 0, 0]},
                              {"t": 2, "position": [2, 0, 0], "rotation": {"axis": [0, 1, 0], "degrees": 90}}]}},
    {"shape": "sphere", "radius": 0.1, "position": [1, 0, 0],
     "motion": {"velocity": [0, 1, 0], "spin": {"axis": [0, 1, 0], "rate": 1.5707963267948966, "centre": [0, 0, 0]}}}])");
  const Scene s = parse_scene(root, "scene.json");
  ASSERT_EQ(s.colliders.size(), 2u);
  const collision::Transform mid = s.colliders[0].motion(1.0);
  EXPECT_NEAR(mid.translation().x(), 1.0, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(mid.linear()).angle(), M_PI / 4, 1e-12);
  const collision::Transform late = s.colliders[0].motion(5.0);
  EXPECT_NEAR(late.translation().x(), 2.0, 1e-12);
  const collision::Transform spun =
      s.colliders[1].motion(1.0);  // quarter turn about y through the origin, up 1 m
  EXPECT_NEAR((spun.translation() - cloth::Vec3(0, 1, -1)).norm(), 0.0, 1e-12);
}

}  // namespace
}  // namespace loom::scene

namespace loom::scene {
namespace {

// An axis of any finite, non-zero length gives a rotation: one whose length overflows double (1e300 per
// component) is used by its direction, not turned into a zero axis that silently disables the collider.
TEST(SceneColliders, HugeRotationAxisIsUsedByItsDirection) {
  for (const char* axis : {"[1e300, 1e300, 0]", "[1e-320, 1e-320, 0]", "[1, 1, 0]"}) {
    nlohmann::json root = base_scene();
    root["colliders"] = nlohmann::json::parse(std::string(R"([{"shape": "box", "half_extents": [1, 1, 1],
        "rotation": {"axis": )") + axis + R"(, "degrees": 90}, "motion": {"spin": {"axis": )" +
                                              axis + R"(, "rate": 1}}}])");
    const Scene s = parse_scene(root, "scene.json");
    ASSERT_EQ(s.colliders.size(), 1u);
    for (double t : {0.0, 0.5}) {
      const auto pose = s.colliders[0].motion(t);
      EXPECT_TRUE(pose.matrix().allFinite()) << axis;
      EXPECT_NEAR((pose.linear() * pose.linear().transpose() - Eigen::Matrix3d::Identity()).norm(), 0.0,
                  1e-12)
          << axis;
      // A quarter turn about (1, 1, 0)/sqrt(2) maps x to (1/2, 1/2, -1/sqrt(2)) (at t = 0, before the spin).
      if (t == 0.0) {
        const cloth::Vec3 x = pose.linear() * cloth::Vec3::UnitX();
        EXPECT_NEAR((x - cloth::Vec3(0.5, 0.5, -std::sqrt(0.5))).norm(), 0.0, 1e-12) << axis;
      }
    }
  }
}

}  // namespace
}  // namespace loom::scene
