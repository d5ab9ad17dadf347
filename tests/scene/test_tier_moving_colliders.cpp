// The tiers' contact promises against colliders that move (docs/scene-format.md, "Quality"): the balanced
// tier leaves no vertex inside a collider at a step's end, for every collider shape, every motion (velocity,
// spin, keyframes) and every solver the tier takes; a cloth pinched between two colliders, where no way out
// exists, is counted (`unresolved`) by the last body-contact stage of every tier.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "loom/cloth/StateArchive.h"
#include "loom/collision/ColliderDistance.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace loom::scene {
namespace {

// Appended last to a simulation: the deepest free vertex inside a collider (m, -signed distance at the
// collider's pose at the step's end), over every step the run kept (a frame the guard rolls back restores
// the depth of its start with the rest of the state).
class PenetrationProbe final : public cloth::Stage {
 public:
  explicit PenetrationProbe(collision::ColliderSetPtr colliders) : colliders_(std::move(colliders)) {}
  const char* name() const override { return "penetration_probe"; }
  void run(cloth::StageContext& ctx) override {
    for (const collision::Collider& c : *colliders_)
      for (const auto& cloth : ctx.cloths) {
        const cloth::ClothState& s = cloth->state();
        for (int i = 0; i < s.size(); ++i)
          if (s.inv_mass[i] > 0.0)
            depth_ = std::max(depth_, -collision::signed_distance(c, c.curr, s.x[i], nullptr));
      }
  }
  void save_state(cloth::StateWriter& out) const override { out.f64(depth_); }
  void load_state(cloth::StateReader& in) override { depth_ = in.f64(); }
  double depth() const { return depth_; }

 private:
  collision::ColliderSetPtr colliders_;
  double depth_ = 0.0;
};

// A 1 m cotton sheet of 11 x 11 nodes at y = 0.6 thrown down at `speed` (m/s) onto `collider`, which rises
// through it; `extra` is merged into the scene's top level.
Scene thrown_sheet(const std::string& quality, double speed, const nlohmann::json& collider,
                   const nlohmann::json& extra = nlohmann::json::object()) {
  nlohmann::json root = nlohmann::json::parse(R"({
    "duration": 0.3, "fps": 30,
    "cloths": [{"name": "c", "mesh": {"type": "grid", "size": [1, 1], "nodes": [11, 11], "plane": "xz",
                "origin": [-0.5, 0.6, -0.5]}, "material": "cotton"}]
  })");
  root["quality"] = quality;
  root["cloths"][0]["velocity"] = {0.0, -speed, 0.0};
  root["colliders"] = nlohmann::json::array({collider});
  for (auto it = extra.begin(); it != extra.end(); ++it) root[it.key()] = it.value();
  return parse_scene(root, "moving.json");
}

// Runs every frame; the deepest vertex inside a collider at any step's end (m).
double deepest(const Scene& sc) {
  collision::ColliderSetPtr colliders;
  auto sim = build_simulation(sc, &colliders);
  auto probe = std::make_unique<PenetrationProbe>(colliders);
  const PenetrationProbe* p = probe.get();
  sim->add_stage(std::move(probe));
  const int frames = sc.frames;
  for (int f = 0; f < frames; ++f) EXPECT_TRUE(sim->step_frame().finite) << "frame " << f + 1;
  return p->depth();
}

// The colliders: each shape with each kind of motion, moving into a sheet that is thrown at it.
struct MovingCase {
  const char* name;
  double speed;  // m/s, the sheet's
  const char* collider;
};

const MovingCase kMoving[] = {
    {"sphere_rising", 10.0,
     R"({"name": "k", "shape": "sphere", "radius": 0.2, "position": [0.1, 0.3, 0],
         "motion": {"velocity": [0, 3, 0]}})"},
    {"capsule_rising_tilted", 20.0,
     R"({"name": "k", "shape": "capsule", "radius": 0.12, "half_height": 0.2, "position": [0.1, 0.3, 0],
         "rotation": {"axis": [1, 0, 0], "degrees": 45}, "motion": {"velocity": [0, 3, 0]}})"},
    {"cylinder_rising_tilted", 20.0,
     R"({"name": "k", "shape": "cylinder", "radius": 0.2, "half_height": 0.2, "position": [0.2, 0.3, 0],
         "rotation": {"axis": [1, 0, 0], "degrees": 45}, "motion": {"velocity": [0, 3, 0]}})"},
    {"box_rising_tilted", 20.0,
     R"({"name": "k", "shape": "box", "half_extents": [0.15, 0.15, 0.15], "position": [0.2, 0.3, 0],
         "rotation": {"axis": [1, 0, 0], "degrees": 45}, "motion": {"velocity": [0, 3, 0]}})"},
    {"box_rising_spinning", 20.0,
     R"({"name": "k", "shape": "box", "half_extents": [0.2, 0.1, 0.15], "position": [0.1, 0.3, 0],
         "rotation": {"axis": [1, 0, 1], "degrees": 30},
         "motion": {"velocity": [0, 5, 0], "spin": {"axis": [0, 1, 0], "rate": 10}}})"},
    {"convex_keyframed_turning", 5.0,
     R"({"name": "k", "shape": "convex", "vertices": [[0, 0, 0], [0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.3],
         [0.3, 0.3, 0.3]], "position": [0, 0.2, 0],
         "motion": {"keyframes": [{"t": 0, "position": [0, 0.2, 0]}, {"t": 0.2, "position": [0, 0.9, 0],
         "rotation": {"axis": [0, 1, 0], "degrees": 180}}]}})"},
    {"mesh_rising_spinning", 20.0,
     R"({"name": "k", "shape": "mesh", "vertices": [[-0.25, 0, -0.25], [0.25, 0, -0.25], [0, 0, 0.3],
         [0, 0.3, 0]], "triangles": [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]], "position": [0, 0.2, 0],
         "motion": {"velocity": [0, 3, 0], "spin": {"axis": [0, 1, 0], "rate": 10}}})"},
    {"plane_rising_tilting", 20.0,
     R"({"name": "k", "shape": "plane", "position": [0, 0.3, 0],
         "motion": {"velocity": [0, 3, 0], "spin": {"axis": [1, 0, 0], "rate": 4}}})"},
};

// Tolerance: 1 µm, a thousandth of cotton's 1 mm contact thickness. The last contact pass projects every
// vertex to one thickness outside; what is left is the closest-point solvers' round-off (convex, mesh).
constexpr double kInsideTolerance = 1e-6;  // m

TEST(TierMovingColliders, BalancedLeavesNoVertexInsideAMovingColliderOfAnyShape) {
  for (const MovingCase& m : kMoving) {
    SCOPED_TRACE(m.name);
    const Scene sc = thrown_sheet("balanced", m.speed, nlohmann::json::parse(m.collider));
    EXPECT_LE(deepest(sc), kInsideTolerance);
  }
}

TEST(TierMovingColliders, BalancedHoldsWithEverySolverItTakes) {
  // A tilted box rising at 3 m/s into a sheet thrown at 5 m/s, 8 steps a frame.
  const nlohmann::json box = nlohmann::json::parse(R"({"name": "k", "shape": "box",
      "half_extents": [0.25, 0.08, 0.15], "position": [0.1, 0.3, 0],
      "rotation": {"axis": [1, 0, 1], "degrees": 30}, "motion": {"velocity": [0, 3, 0]}})");
  for (const char* method :
       {"implicit_euler", "imex", "projective", "desbrun", "pbd", "xpbd", "fast_xpbd", "bdf2", "verlet"}) {
    SCOPED_TRACE(method);
    const Scene sc = thrown_sheet("balanced", 5.0, box, {{"solver", {{"method", method}, {"substeps", 8}}}});
    EXPECT_LE(deepest(sc), kInsideTolerance);
  }
}

// The realtime tier's promise, on the same colliders (it has held; kept so that both tiers stay alike).
TEST(TierMovingColliders, RealtimeLeavesNoVertexInsideAMovingColliderOfAnyShape) {
  for (const MovingCase& m : kMoving) {
    SCOPED_TRACE(m.name);
    const Scene sc = thrown_sheet("realtime", m.speed, nlohmann::json::parse(m.collider));
    EXPECT_LE(deepest(sc), kInsideTolerance);
  }
}

// The `unresolved` counter of the last body-contact stage (-1: none).
double last_contact_unresolved(const cloth::Simulation& sim) {
  double unresolved = -1.0;
  for (const cloth::StageProfile& p : sim.profile())
    if (p.name == "body_collision" || p.name == "realtime_contact" || p.name == "realtime_contact_final")
      for (const auto& [k, v] : p.counters)
        if (k == "unresolved") unresolved = v;
  return unresolved;
}

// A sheet on a box with a second box coming down onto it: the cloth between them has no way out. The last
// body-contact stage of every tier counts the vertices it leaves inside (`unresolved`).
double pinched(const std::string& quality) {
  nlohmann::json root = nlohmann::json::parse(R"({
    "duration": 0.75, "fps": 60,
    "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [1, 1], "nodes": [25, 25], "plane": "xz",
                "origin": [-0.5, 0.5, -0.5]}, "material": {"preset": "cotton"}, "mass": 0.2}],
    "colliders": [{"name": "lo", "shape": "box", "half_extents": [0.3, 0.1, 0.3], "position": [0, 0.1, 0]},
                  {"name": "hi", "shape": "box", "half_extents": [0.2, 0.05, 0.2], "position": [0, 0.8, 0],
                   "motion": {"velocity": [0, -1, 0]}}]
  })");
  root["quality"] = quality;
  if (quality == "reference") root["solver"] = {{"method", "implicit_euler"}, {"substeps", 4}};
  const Scene sc = parse_scene(root, "pinch.json");
  auto sim = build_simulation(sc);
  const int frames = sc.frames;
  for (int f = 0; f < frames; ++f) sim->step_frame();
  return last_contact_unresolved(*sim);
}

TEST(TierMovingColliders, EveryTierCountsACrushedCloth) {
  for (const char* quality : {"reference", "balanced", "realtime"}) {
    SCOPED_TRACE(quality);
    EXPECT_GT(pinched(quality), 0.0);
  }
}

// The counter's control: a sheet the moving colliders above push but do not pinch counts nothing.
TEST(TierMovingColliders, NoPinchCountsNothing) {
  for (const char* quality : {"reference", "balanced", "realtime"}) {
    SCOPED_TRACE(quality);
    const Scene sc = thrown_sheet(quality, 5.0, nlohmann::json::parse(kMoving[0].collider));
    auto sim = build_simulation(sc);
    for (int f = 0; f < 9; ++f) sim->step_frame();
    EXPECT_EQ(last_contact_unresolved(*sim), 0.0);
  }
}

}  // namespace
}  // namespace loom::scene
