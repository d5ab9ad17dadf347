// Every collision and guard stage, restored to a state saved before its first run (the guard's retry of
// frame 0, a checkpoint written at frame 0) and run again: no crash (the sanitizer build runs this), every
// position finite. The body-contact stages at the largest contact thickness a scene may give
// (kMaxContactThickness, 2 cm) with the cloth starting almost all of it inside the padding: the push out
// stays bounded (no explosion, no NaN).
#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "BodyContactTestUtil.h"
#include "SymplecticSetup.h"
#include "loom/cloth/Simulation.h"
#include "loom/cloth/StateArchive.h"
#include "loom/collision/BodyCollisionStage.h"
#include "loom/collision/ContactGuardStage.h"
#include "loom/collision/FeatureContact.h"
#include "loom/collision/IntersectionGuardStage.h"
#include "loom/collision/RealtimeBodyContact.h"
#include "loom/collision/RealtimeSelfCollision.h"
#include "loom/collision/SelfCollisionStage.h"

namespace loom::collision {
namespace {

using namespace loom::collision::test;

using StageFactory = std::function<std::unique_ptr<cloth::Stage>(const ColliderSetPtr&)>;

struct NamedStage {
  const char* name;
  StageFactory make;
  bool body_contact;  // pushes cloth out of colliders
};

std::vector<NamedStage> stages() {
  return {
      {"body_collision", [](const ColliderSetPtr& s) { return std::make_unique<BodyCollisionStage>(s); },
       true},
      {"feature_contact", [](const ColliderSetPtr& s) { return std::make_unique<FeatureContactStage>(s); },
       true},
      {"realtime_body_contact",
       [](const ColliderSetPtr& s) { return std::make_unique<RealtimeBodyContactStage>(s); }, true},
      {"contact_guard", [](const ColliderSetPtr& s) { return std::make_unique<ContactGuardStage>(s, 0.05); },
       false},
      {"intersection_guard", [](const ColliderSetPtr&) { return std::make_unique<IntersectionGuardStage>(); },
       false},
      {"self_collision",
       [](const ColliderSetPtr&) { return std::make_unique<SelfCollisionStage>(SelfCollisionSettings{}); },
       false},
      {"realtime_self",
       [](const ColliderSetPtr&) {
         return std::make_unique<RealtimeSelfCollisionStage>(RealtimeSelfSettings{});
       },
       false},
  };
}

// Two sheets 5 mm apart, the lower one `gap` above a sphere of radius 0.3 (top at y = 0.3).
SimulationSetup two_sheets(double gap = 0.01) {
  SimulationSetup s = loom::test::symplectic_setup();
  s.cloths.push_back(sheet(6, 0.4, cloth::GridPlane::kXZ, Vec3(-0.2, 0.3 + gap, -0.2)));
  s.cloths.push_back(sheet(6, 0.4, cloth::GridPlane::kXZ, Vec3(-0.2, 0.305 + gap, -0.2)));
  s.substeps = 20;
  return s;
}

void expect_finite(const Simulation& sim, const std::string& what) {
  for (const auto& c : sim.cloths())
    for (const Vec3& x : c->state().x) ASSERT_TRUE(x.allFinite()) << what;
}

TEST(StageRestore, AStateSavedBeforeTheFirstRunRestoresCleanlyInEveryStage) {
  for (const NamedStage& st : stages()) {
    Simulation sim(two_sheets());
    auto set = std::make_shared<ColliderSet>(1, shape(ShapeType::sphere, 0.3));
    sim.add_stage(st.make(set));
    cloth::StateWriter before;
    sim.save_state(before);  // no stage has run yet
    sim.step_frame();
    expect_finite(sim, st.name);
    cloth::StateReader in(before.data(), "frame start");
    sim.load_state(in);
    EXPECT_EQ(sim.frame(), 0) << st.name;
    for (int f = 0; f < 3; ++f) sim.step_frame();
    expect_finite(sim, st.name);
    // The stage alone, restored from a state it saved before it ever ran, into one that has run.
    std::unique_ptr<cloth::Stage> fresh = st.make(set), used = st.make(set);
    cloth::StateWriter empty;
    fresh->save_state(empty);
    cloth::StageContext ctx{sim.cloths(), sim.time(), 1e-3, 1};
    used->run(ctx);
    cloth::StateReader back(empty.data(), "stage start");
    used->load_state(back);
    used->run(ctx);
    expect_finite(sim, std::string(st.name) + " (stage alone)");
  }
}

TEST(StageRestore, TheLargestContactThicknessPushesOutWithoutExplosion) {
  constexpr double kThickness = 0.02;  // m, kMaxContactThickness of the scene layer
  for (const NamedStage& st : stages()) {
    if (!st.body_contact) continue;
    for (const ShapeType type : {ShapeType::sphere, ShapeType::box, ShapeType::plane}) {
      Simulation sim(two_sheets(0.001));
      Collider c = type == ShapeType::box ? shape(type, 0, 0, Vec3(0.3, 0.3, 0.3)) : shape(type, 0.3);
      if (type == ShapeType::plane) c.curr = c.prev = at(Vec3(0, 0.3, 0));
      c.thickness = kThickness;  // the sheets start 1 mm from the surface: 19 mm inside the padding
      auto set = std::make_shared<ColliderSet>(1, c);
      sim.add_stage(st.make(set));
      for (int f = 0; f < 30; ++f) sim.step_frame();
      expect_finite(sim, st.name);
      // Pushed out to the padding, never flung away: every vertex within a metre of where it started and
      // slower than 5 m/s.
      for (const auto& cl : sim.cloths())
        for (int i = 0; i < cl->state().size(); ++i) {
          EXPECT_LT(cl->state().x[i].y(), 1.0) << st.name << " " << static_cast<int>(type);
          EXPECT_LT(cl->state().v[i].norm(), 5.0) << st.name << " " << static_cast<int>(type);
        }
      EXPECT_GT(worst_gap(sim.cloths()[0]->state(), *set, kThickness), -0.5 * kThickness)
          << st.name << " " << static_cast<int>(type);
    }
  }
}

}  // namespace
}  // namespace loom::collision
