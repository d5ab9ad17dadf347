// The scene key `quality` in a Bullet world (SceneQuality.h, WorldTier): "realtime" and "balanced" run the
// bridge's coupled tier (BulletClothSettings::Tier::realtime), "reference" its setup tier with the scene's
// solver; the explicit values that apply in the coupled tier win over it, an explicit solver it cannot run
// selects the setup tier, and keys it would ignore are refused naming the field.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "loom/bullet/BulletScene.h"
#include "loom/cloth/Error.h"
#include "loom/scene/Scene.h"
#include "loom/scene/ScenePipeline.h"

namespace loom::test {
namespace {

// A 9 x 9 sheet pinned at its corners (tied to a static post by the first corner) and a box above it.
scene::Scene world(const nlohmann::json& extra) {
  nlohmann::json root = nlohmann::json::parse(R"({
    "duration": 0.25, "fps": 60,
    "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [1, 1], "nodes": [9, 9], "plane": "xz",
                "origin": [-0.5, 0.5, -0.5]}, "material": {"preset": "cotton"},
                "pins": [{"grid": [0, 0]}, {"grid": [-1, 0]}, {"grid": [0, -1]}, {"grid": [-1, -1]}]}],
    "bodies": [{"name": "box", "shape": "box", "half_extents": [0.1, 0.1, 0.1], "mass": 0.5,
                "position": [0, 0.7, 0]}]
  })");
  for (auto it = extra.begin(); it != extra.end(); ++it) root[it.key()] = it.value();
  return scene::parse_scene(root, "world.json");
}

bool has(const std::vector<std::string>& names, const std::string& n) {
  return std::find(names.begin(), names.end(), n) != names.end();
}

// The pipeline `loom run` builds; `frames` frames run.
struct Built {
  bool coupled = false;
  std::string solver;
  double iterations = 0.0;
  int steps = 0;  // cloth steps per Bullet substep
  std::vector<std::string> stages;
  double box_y = 0.0;  // m, after the frames
  bool finite = true;
};

Built build(const scene::Scene& sc, int frames = 0) {
  auto p = scene::build_pipeline(sc);
  Built b;
  b.coupled = p->bullet()->options().realtime;
  b.solver = p->simulation().setup().solver.method;
  const auto it = p->simulation().setup().solver.params.find("iterations");
  b.iterations = it == p->simulation().setup().solver.params.end() ? 0.0 : it->second;
  b.steps = p->simulation().setup().substeps;
  b.stages = p->simulation().stage_names();
  for (int f = 0; f < frames; ++f) b.finite = b.finite && p->step_frame().finite;
  b.box_y = p->bullet()->body_position(0).y();
  return b;
}

TEST(BulletQuality, RealtimeRunsTheCoupledTier) {
  const scene::Scene sc = world({{"quality", "realtime"}});
  EXPECT_TRUE(sc.world.coupled);
  EXPECT_FALSE(sc.setup.tethers);  // the coupled solve has its own tethers
  const Built b = build(sc, 15);
  EXPECT_TRUE(b.coupled);
  EXPECT_EQ(b.solver, "xpbd");
  EXPECT_TRUE(has(b.stages, "body_coupling"));
  EXPECT_FALSE(has(b.stages, "feature_contact"));
  EXPECT_FALSE(has(b.stages, "tethers"));
  EXPECT_EQ(b.steps,
            2);  // the bridge's 2 coupled steps per Bullet substep, not the cloth tier's 12 per frame
  EXPECT_TRUE(b.finite);
  // The box fell onto the sheet and lies on it: sheet at 0.5, box half size 0.1, and the sheet's centre
  // (0.707 m from each pin) sags at most sqrt(1.015^2 - 1) 0.707 = 0.123 m under the tier's 1.5 % tether
  // slack.
  EXPECT_GT(b.box_y, 0.47);
  EXPECT_LT(b.box_y, 0.7);
}

TEST(BulletQuality, ReferenceAndNoKeyRunTheSetupTierWithTheScenesSolver) {
  for (const nlohmann::json& extra :
       {nlohmann::json{{"solver", {{"method", "implicit_euler"}, {"substeps", 8}}}},
        nlohmann::json{{"quality", "reference"},
                       {"solver", {{"method", "implicit_euler"}, {"substeps", 8}}}}}) {
    const Built b = build(world(extra), 15);
    EXPECT_FALSE(b.coupled) << extra.dump();
    EXPECT_EQ(b.solver, "implicit_euler");
    EXPECT_EQ(b.steps, 2);  // 8 per frame over 4 Bullet substeps
    EXPECT_TRUE(has(b.stages, "feature_contact"));
    EXPECT_FALSE(has(b.stages, "body_coupling"));
    EXPECT_TRUE(b.finite);
  }
}

TEST(BulletQuality, BalancedIsTheCoupledTierAtTwiceTheSteps) {
  const scene::Scene sc = world({{"quality", "balanced"}});
  const bullet::BulletSceneOptions o = scene::bullet_scene_options(sc);
  EXPECT_TRUE(o.realtime);
  EXPECT_EQ(o.frame_steps, 16);
  EXPECT_EQ(o.coupling_iterations, 4);
  const Built b = build(sc);
  EXPECT_TRUE(b.coupled);
  EXPECT_EQ(b.steps, 4);
}

TEST(BulletQuality, ExplicitValuesWin) {
  {  // a position-based solver, its iterations and substeps, the strain limit and the tethers' slack
    const scene::Scene sc =
        world({{"quality", "realtime"},
               {"solver", {{"method", "pbd"}, {"iterations", 3}, {"substeps", 24}}},
               {"constraints", {{"strain_limit", {{"max_stretch", 0.05}}}, {"tethers", {{"slack", 0.02}}}}}});
    const bullet::BulletSceneOptions o = scene::bullet_scene_options(sc);
    EXPECT_TRUE(o.realtime);
    EXPECT_EQ(o.realtime_solver, "pbd");
    EXPECT_EQ(o.realtime_iterations, 3);
    EXPECT_EQ(o.frame_steps, 24);
    EXPECT_DOUBLE_EQ(o.max_stretch, 0.05);
    EXPECT_DOUBLE_EQ(o.tether_stretch, 0.02);
    const Built b = build(sc);
    EXPECT_TRUE(b.coupled);
    EXPECT_EQ(b.solver, "pbd");
    EXPECT_EQ(b.iterations, 3.0);
    EXPECT_EQ(b.steps, 6);  // 24 per frame over 4 Bullet substeps
  }
  {  // a solver the coupled solve cannot run: the setup tier runs it
    const Built b = build(world({{"quality", "realtime"}, {"solver", {{"method", "implicit_euler"}}}}));
    EXPECT_FALSE(b.coupled);
    EXPECT_EQ(b.solver, "implicit_euler");
    EXPECT_TRUE(has(b.stages, "feature_contact"));
  }
}

TEST(BulletQuality, BadValuesRefusedNamingTheField) {
  auto error = [](const nlohmann::json& extra) -> std::string {
    try {
      world(extra);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  const std::string q = error({{"quality", "fast"}});
  EXPECT_NE(q.find("world.json"), std::string::npos) << q;
  EXPECT_NE(q.find("quality"), std::string::npos) << q;
  EXPECT_NE(q.find("realtime"), std::string::npos) << q;  // the allowed names
  const std::string c =
      error({{"quality", "realtime"}, {"solver", {{"method", "xpbd"}, {"compliance_scale", 0.5}}}});
  EXPECT_NE(c.find("solver.compliance_scale"), std::string::npos) << c;
  EXPECT_NE(c.find("coupled"), std::string::npos) << c;
  const std::string t =
      error({{"quality", "realtime"}, {"constraints", {{"tethers", {{"distance", "euclidean"}}}}}});
  EXPECT_NE(t.find("constraints.tethers.distance"), std::string::npos) << t;
  // In the setup tier the same keys are the solver's and the tether pass's own.
  EXPECT_EQ(error({{"quality", "reference"}, {"solver", {{"method", "xpbd"}, {"compliance_scale", 0.5}}}}),
            "");
}

}  // namespace
}  // namespace loom::test
