// The scene key `quality` (SceneQuality.h): one word picks solver, substeps, constraint passes and the
// collision stages together; every explicit scene value wins over the tier; without the key a scene is
// exactly what it names (the reference tier adds nothing).
#include <gtest/gtest.h>

#include <string>

#include "loom/cloth/Error.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace loom::scene {
namespace {

// A sheet, a sphere under it and self-collision; `extra` is merged into the scene's top level.
Scene parse(const nlohmann::json& extra) {
  nlohmann::json root = nlohmann::json::parse(R"({
    "duration": 0.05, "fps": 60,
    "collision": {"self": true},
    "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [1, 1], "nodes": [9, 9], "plane": "xz",
                "origin": [-0.5, 0.5, -0.5]}, "mass": 0.2}],
    "colliders": [{"name": "ball", "shape": "sphere", "radius": 0.2, "position": [0, 0.2, 0]}]
  })");
  for (auto it = extra.begin(); it != extra.end(); ++it) root[it.key()] = it.value();
  return parse_scene(root, "tier.json");
}

std::vector<std::string> stage_names(const Scene& sc) {
  const auto sim = build_simulation(sc);
  return sim->stage_names();
}

bool has(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

TEST(QualityTiers, WithoutTheKeyASceneIsWhatItNames) {
  const Scene sc = parse(nlohmann::json::object());
  EXPECT_EQ(sc.quality.name, "reference");
  EXPECT_EQ(sc.setup.solver.method, "symplectic_euler");
  EXPECT_EQ(sc.setup.substeps, 1);
  EXPECT_TRUE(sc.setup.solver.params.empty());
  EXPECT_FALSE(sc.realtime_contact);
  EXPECT_FALSE(sc.proximity);
  EXPECT_FALSE(sc.setup.strain_limit);
  EXPECT_FALSE(sc.strain_limit_after_contact);
  const auto names = stage_names(sc);
  EXPECT_TRUE(has(names, "body_collision"));
  EXPECT_TRUE(has(names, "self_collision"));
  EXPECT_FALSE(has(names, "realtime_contact"));
}

TEST(QualityTiers, ReferenceIsTheSameAsNoKey) {
  const Scene a = parse(nlohmann::json::object()), b = parse({{"quality", "reference"}});
  EXPECT_EQ(a.setup.solver.method, b.setup.solver.method);
  EXPECT_EQ(a.setup.substeps, b.setup.substeps);
  EXPECT_EQ(stage_names(a), stage_names(b));
}

TEST(QualityTiers, RealtimePicksSolverContactAndChecksTogether) {
  const Scene sc = parse({{"quality", "realtime"}});
  EXPECT_EQ(sc.setup.solver.method, "fast_xpbd");
  EXPECT_EQ(sc.setup.substeps, 12);
  EXPECT_EQ(sc.setup.solver.params.at("iterations"), 1.0);
  EXPECT_TRUE(sc.realtime_contact);
  ASSERT_TRUE(sc.proximity);
  EXPECT_EQ(sc.proximity->every, 2);
  EXPECT_TRUE(sc.strain_limit_after_contact);
  EXPECT_TRUE(sc.setup.tethers);
  // Order: solver, tethers, cloth-cloth proximity, body contact, strain limit, body contact (positions).
  const auto names = stage_names(sc);
  const auto at = [&](const std::string& s) {
    return std::find(names.begin(), names.end(), s) - names.begin();
  };
  EXPECT_LT(at("solve"), at("realtime_self_collision"));
  EXPECT_LT(at("realtime_self_collision"), at("realtime_contact"));
  EXPECT_LT(at("realtime_contact"), at("strain_limit"));
  EXPECT_LT(at("strain_limit"), at("realtime_contact_final"));
  EXPECT_FALSE(has(names, "body_collision"));
  EXPECT_FALSE(has(names, "self_collision"));
}

TEST(QualityTiers, BalancedUsesExactBodyCollisionAndProximityBetweenCloths) {
  const Scene sc = parse({{"quality", "balanced"}});
  EXPECT_EQ(sc.setup.solver.method, "fast_xpbd");
  EXPECT_EQ(sc.setup.substeps, 32);
  EXPECT_FALSE(sc.realtime_contact);
  ASSERT_TRUE(sc.proximity);
  const auto names = stage_names(sc);
  EXPECT_TRUE(has(names, "body_collision"));
  EXPECT_TRUE(has(names, "realtime_self_collision"));
  EXPECT_TRUE(has(names, "strain_limit"));
}

TEST(QualityTiers, ExplicitValuesWin) {
  {  // another solver: the tier's substeps and iterations go with its own solver only
    const Scene sc = parse({{"quality", "realtime"}, {"solver", {{"method", "implicit_euler"}}}});
    EXPECT_EQ(sc.setup.solver.method, "implicit_euler");
    EXPECT_EQ(sc.setup.substeps, 1);
    EXPECT_TRUE(sc.setup.solver.params.empty());
    EXPECT_TRUE(sc.realtime_contact);  // the rest of the tier stays
  }
  {  // the tier's solver with explicit substeps and iterations
    const Scene sc = parse({{"quality", "realtime"}, {"solver", {{"substeps", 30}, {"iterations", 3}}}});
    EXPECT_EQ(sc.setup.solver.method, "fast_xpbd");
    EXPECT_EQ(sc.setup.substeps, 30);
    EXPECT_EQ(sc.setup.solver.params.at("iterations"), 3.0);
  }
  {  // explicit collision method, body contact and strain limiting
    nlohmann::json extra = {{"quality", "realtime"},
                            {"body_contact", "exact"},
                            {"constraints", {{"strain_limit", {{"max_stretch", 0.05}}}}}};
    extra["collision"] = {{"self", true}, {"method", "exact"}};
    const Scene sc = parse(extra);
    EXPECT_FALSE(sc.realtime_contact);
    EXPECT_FALSE(sc.proximity);
    ASSERT_TRUE(sc.setup.strain_limit);
    EXPECT_EQ(sc.setup.strain_limit->max_stretch, 0.05);
    EXPECT_FALSE(sc.strain_limit_after_contact);
  }
  {  // proximity asked for in the reference tier
    nlohmann::json extra = {
        {"collision", {{"self", true}, {"method", "proximity"}, {"thickness", 0.01}, {"every", 3}}}};
    const Scene sc = parse(extra);
    ASSERT_TRUE(sc.proximity);
    EXPECT_EQ(sc.proximity->thickness, 0.01);
    EXPECT_EQ(sc.proximity->every, 3);
    EXPECT_EQ(sc.setup.solver.method, "symplectic_euler");
  }
}

TEST(QualityTiers, BadValuesNameTheField) {
  auto message = [](const nlohmann::json& extra) {
    try {
      parse(extra);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string q = message({{"quality", "fast"}});
  EXPECT_NE(q.find("tier.json"), std::string::npos) << q;
  EXPECT_NE(q.find("quality"), std::string::npos) << q;
  EXPECT_NE(q.find("realtime"), std::string::npos) << q;  // the allowed names
  const std::string b = message({{"body_contact", "fast"}});
  EXPECT_NE(b.find("body_contact"), std::string::npos) << b;
  nlohmann::json c = {{"quality", "realtime"}};
  c["collision"] = {{"self", true}, {"every", 0}};
  const std::string e = message(c);
  EXPECT_NE(e.find("collision.every"), std::string::npos) << e;
}

TEST(QualityTiers, CharacterScenesUseRealtimeAndKeepAReferenceVariant) {
  for (const char* name : {"character_layers", "character_cape", "character_skirt", "character_shirt"}) {
    const std::string dir = std::string(LOOM_SOURCE_DIR) + "/scenes/";
    const nlohmann::json rt = read_json_file(dir + name + ".json");
    const nlohmann::json ref = read_json_file(dir + name + "_reference.json");
    EXPECT_EQ(rt.at("quality"), "realtime") << name;
    EXPECT_FALSE(rt.contains("solver")) << name << ": an explicit solver would override the tier";
    EXPECT_EQ(ref.at("quality"), "reference") << name;
    EXPECT_EQ(ref.at("solver").at("method"), "implicit_euler") << name;
  }
}

}  // namespace
}  // namespace loom::scene
