// The guard's contact check and the colliders' work (collision::ContactGuardStage, cloth/Guard.h):
// a sheet squeezed between the floor and a lid that comes down below the floor cannot be resolved; the run
// must stop with "could not resolve contacts: vertex V of cloth C is D mm inside collider K", the last good
// frame kept, after the guard has retried the frame with smaller steps.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "loom/collision/ContactGuardStage.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace loom {
namespace {

// A 0.5 m sheet of 5x5 nodes resting on the floor; the lid (a plane, solid above) comes down from 0.1 m to
// `lid_end` (m) over 0.1 s.
std::unique_ptr<cloth::Simulation> squeezed(double lid_end, double max_penetration,
                                            collision::ColliderSetPtr* cs) {
  const std::string text = R"({
    "duration": 0.3, "fps": 60, "solver": {"method": "implicit_euler", "substeps": 2},
    "guard": {"max_penetration": @MAXPEN, "max_halvings": 2},
    "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [0.5, 0.5], "nodes": [5, 5], "plane": "xz", "origin": [-0.25, 0.006, -0.25]},
                "material": {"preset": "cotton"}, "mass": 0.05}],
    "colliders": [{"name": "floor", "shape": "plane", "thickness": 0.005},
                  {"name": "lid", "shape": "plane", "thickness": 0.005, "rotation": {"axis": [1, 0, 0], "degrees": 180},
                   "motion": {"keyframes": [{"t": 0, "position": [0, 0.1, 0]}, {"t": 0.1, "position": [0, @LID, 0]}]}}]
  })";
  std::string s = text;
  s.replace(s.find("@MAXPEN"), 7, std::to_string(max_penetration));
  s.replace(s.find("@LID"), 4, std::to_string(lid_end));
  const scene::Scene sc = scene::parse_scene(nlohmann::json::parse(s), "squeezed.json");
  return scene::build_simulation(sc, cs);
}

TEST(ContactGuard, UnresolvableContactStopsTheRunAtTheLastGoodFrame) {
  collision::ColliderSetPtr cs;
  auto sim = squeezed(-0.05, 1e-3, &cs);
  bool has_stage = false;
  for (const std::string& n : sim->stage_names()) has_stage = has_stage || n == "contact_guard";
  ASSERT_TRUE(has_stage);
  cloth::StateWriter before;
  int f = 1;
  cloth::FrameStats st;
  for (; f <= 18; ++f) {
    before.clear();
    sim->save_state(before);
    st = sim->step_frame();
    ASSERT_TRUE(sim->cloths()[0]->state().is_finite());
    if (!st.finite) break;
  }
  ASSERT_FALSE(st.finite) << "the lid went through the floor and the sheet was not reported";
  const std::string& why = sim->failure();
  EXPECT_NE(why.find("could not resolve contacts: vertex "), std::string::npos) << why;
  EXPECT_NE(why.find(" of cloth 'sheet' is "), std::string::npos) << why;
  EXPECT_TRUE(why.find("inside collider 'lid'") != std::string::npos ||
              why.find("inside collider 'floor'") != std::string::npos)
      << why;
  EXPECT_NE(why.find("(limit 1 mm)"), std::string::npos) << why;
  EXPECT_NE(why.find("also with 8 substeps"), std::string::npos) << why;  // 2 substeps, retried with 4 and 8
  EXPECT_EQ(sim->frame(), f - 1);
  cloth::StateWriter after;
  sim->save_state(after);
  EXPECT_EQ(before.data(), after.data());  // exactly the last good frame
}

TEST(ContactGuard, ResolvableContactRunsThrough) {
  // The lid stops 30 mm above the floor: room for the sheet and both thicknesses; no violation, and the
  // deepest vertex inside a collider is 0.
  collision::ColliderSetPtr cs;
  auto sim = squeezed(0.03, 1e-3, &cs);
  for (int f = 1; f <= 18; ++f) ASSERT_TRUE(sim->step_frame().finite) << sim->failure();
  for (const cloth::StageProfile& p : sim->profile())
    if (p.name == "contact_guard") {
      ASSERT_EQ(p.counters[0].first, "deepest_mm");
      EXPECT_EQ(p.counters[0].second, 0.0);
    }
}

TEST(ContactGuard, ColliderWorkIsImpulseTimesVelocity) {
  // One box moving at 2 m/s along x and turning at 3 rad/s about y over a 0.01 s step, its reaction changed
  // by J = (0.5, 0.1, 0) N s and L = (0, 0.2, 0.4) N m s: work |J·v| + |L·ω| = 1.0 + 0.6 J.
  auto cs = std::make_shared<collision::ColliderSet>(1);
  collision::Collider& c = (*cs)[0];
  c.name = "box";
  c.shape.type = collision::ShapeType::box;
  c.shape.half_extents = cloth::Vec3(0.1, 0.1, 0.1);
  c.prev = collision::Transform::Identity();
  c.curr =
      collision::Transform(Eigen::Translation3d(0.02, 0, 0) * Eigen::AngleAxisd(0.03, cloth::Vec3::UnitY()));
  collision::ContactGuardStage stage(cs, 1e-3);
  std::vector<std::unique_ptr<cloth::Cloth>> none;
  cloth::StageContext ctx{none, 0.0, 0.01, 1};
  stage.run(ctx);
  EXPECT_EQ(stage.work_in(), 0.0);
  c.reaction_impulse = cloth::Vec3(0.5, 0.1, 0.0);
  c.reaction_angular_impulse = cloth::Vec3(0.0, 0.2, 0.4);
  stage.run(ctx);
  EXPECT_NEAR(stage.work_in(), 1.6, 1e-12);
  EXPECT_EQ(stage.violation(), "");
  // Saved and restored with the state (the guard's rollback): the same work, the same reference impulses.
  cloth::StateWriter w;
  stage.save_state(w);
  collision::ContactGuardStage copy(cs, 1e-3);
  cloth::StateReader r(w.data(), "(test)");
  copy.load_state(r);
  EXPECT_EQ(copy.work_in(), stage.work_in());
  copy.run(ctx);  // no further change of the reaction: no work
  EXPECT_NEAR(copy.work_in(), 1.6, 1e-12);
}

}  // namespace
}  // namespace loom
