// loom-view's simulation logic without a display (apps/viewer/LiveScene.h): effect toggles remove and
// restore their stages and terms, material edits rebuild the cloth (mass follows the areal density), both
// keep the clock and the cloth's state, an invalid edit keeps the old run, and a vertex picked with a ray
// is the one under the cursor and follows the mouse target exactly as a temporary kinematic pin.
// With the Bullet bridge: a scene with rigid `bodies` runs in a Bullet world (the box moves, the colliders
// are the bodies), picking returns what BulletCloth::ray_test and a brute-force cast return, and dragging
// works there too.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "LiveScene.h"
#include "loom/scene/Scene.h"
#ifdef LOOM_HAVE_BULLET
#include "loom/bullet/BulletCloth.h"
#include "loom/bullet/BulletScene.h"
#include "loom/bullet/ClothRay.h"
#endif

namespace loom::viewer {
namespace {

using cloth::Vec3;

scene::Scene small_scene(const std::string& solver = "symplectic_euler", int substeps = 20) {
  return scene::load_scene(
      std::string(LOOM_SOURCE_DIR) + "/scenes/hanging_cloth.json",
      {"cloths.0.mesh.nodes=[9, 9]", "solver.method=" + solver, "solver.substeps=" + std::to_string(substeps),
       "effects={\"drag\": {\"isotropic\": 0.5}}",
       "constraints={\"strain_limit\": {\"max_stretch\": 0.1}, \"tethers\": {\"slack\": 0.0}}"});
}

bool has(const std::vector<std::string>& names, const std::string& n) {
  return std::find(names.begin(), names.end(), n) != names.end();
}

double total_mass(const cloth::Simulation& sim) {
  double m = 0.0;
  for (double mi : sim.cloths()[0]->state().mass) m += mi;
  return m;
}

TEST(LiveScene, TogglesRemoveAndRestoreEffectsKeepingClockAndState) {
  LiveScene live(small_scene());
  EXPECT_TRUE(live.available().drag);
  EXPECT_TRUE(live.available().strain_limit);
  EXPECT_TRUE(live.available().tethers);
  EXPECT_FALSE(live.available().colliders);
  for (int f = 0; f < 5; ++f) live.step_frame();
  const cloth::Vec3s x = live.sim().cloths()[0]->state().x, v = live.sim().cloths()[0]->state().v;
  const double t = live.sim().time();
  std::vector<std::string> names = live.sim().stage_names();
  ASSERT_TRUE(has(names, "strain_limit") && has(names, "tethers") && has(names, "solve/drag"));

  live.enabled().strain_limit = live.enabled().tethers = live.enabled().drag = false;
  live.rebuild();
  names = live.sim().stage_names();
  EXPECT_FALSE(has(names, "strain_limit"));
  EXPECT_FALSE(has(names, "tethers"));
  EXPECT_FALSE(has(names, "solve/drag"));
  EXPECT_EQ(live.sim().frame(), 5);
  EXPECT_DOUBLE_EQ(live.sim().time(), t);
  EXPECT_EQ(live.sim().cloths()[0]->state().x, x);
  EXPECT_EQ(live.sim().cloths()[0]->state().v, v);
  live.step_frame();
  EXPECT_EQ(live.sim().frame(), 6);

  live.enabled().tethers = true;
  live.rebuild();
  names = live.sim().stage_names();
  EXPECT_TRUE(has(names, "tethers"));
  EXPECT_FALSE(has(names, "strain_limit"));
  live.restart();
  EXPECT_EQ(live.sim().frame(), 0);
}

TEST(LiveScene, MaterialEditsRebuildTheClothAndBadEditsKeepTheRun) {
  LiveScene live(small_scene());
  for (int f = 0; f < 3; ++f) live.step_frame();
  const cloth::Vec3s x = live.sim().cloths()[0]->state().x;
  const double m0 = total_mass(live.sim());
  cloth::Material& mat = live.materials()[0];
  mat.areal_density *= 2.0;
  mat.stretch_warp *= 3.0;
  mat.bend_weft *= 10.0;
  live.rebuild();
  EXPECT_NEAR(total_mass(live.sim()), 2.0 * m0, 1e-12 * m0);
  EXPECT_EQ(live.sim().cloths()[0]->material().stretch_warp, mat.stretch_warp);
  EXPECT_EQ(live.sim().cloths()[0]->material().bend_weft, mat.bend_weft);
  EXPECT_EQ(live.sim().cloths()[0]->state().x, x);
  EXPECT_EQ(live.sim().frame(), 3);

  const double density = mat.areal_density;
  mat.areal_density = -1.0;
  EXPECT_THROW(live.rebuild(), std::exception);
  EXPECT_EQ(live.sim().cloths()[0]->material().areal_density, density);  // the old run goes on
  EXPECT_EQ(live.sim().frame(), 3);
  live.step_frame();
  EXPECT_EQ(live.sim().frame(), 4);
}

class LiveSceneDrag : public ::testing::TestWithParam<const char*> {};

// Explicit and implicit integrators both honour the kinematic contract for the grabbed vertex.
TEST_P(LiveSceneDrag, PickedVertexIsTheOneUnderTheRayAndFollowsTheTarget) {
  LiveScene live(small_scene(GetParam(), std::string(GetParam()) == "symplectic_euler" ? 20 : 2));
  const cloth::ClothState& s0 = live.sim().cloths()[0]->state();
  // The free corner far from the pinned edge: the vertex with the largest x + z among free vertices.
  int corner = -1;
  for (int i = 0; i < static_cast<int>(s0.x.size()); ++i)
    if (s0.inv_mass[i] > 0 && (corner < 0 || s0.x[i].x() + s0.x[i].z() > s0.x[corner].x() + s0.x[corner].z()))
      corner = i;
  const double inv_mass = s0.inv_mass[corner];
  const Vec3 p = s0.x[corner];
  // A ray from above, slanted, hitting the sheet a little inside the corner.
  const Vec3 hit = p + Vec3(-0.02, 0.0, -0.03), origin = hit + Vec3(0.3, 2.0, 0.1);
  EXPECT_FALSE(live.grab(origin + Vec3(5, 0, 0), hit - origin));  // misses the sheet
  ASSERT_TRUE(live.grab(origin, hit - origin));
  ASSERT_TRUE(live.grabbed());
  EXPECT_EQ(live.grabbed()->vertex, corner);
  EXPECT_NEAR(live.grabbed()->distance, (hit - origin).norm(), 1e-9);
  EXPECT_EQ(live.sim().cloths()[0]->state().inv_mass[corner], 0.0);

  // Pulled up and sideways over two frames: exactly at the target after each frame.
  for (const Vec3& target : {Vec3(p + Vec3(0.1, 0.3, 0.0)), Vec3(p + Vec3(0.15, 0.5, 0.05))}) {
    live.drag_to(target);
    live.step_frame();
    EXPECT_LT((live.sim().cloths()[0]->state().x[corner] - target).norm(), 1e-12);
  }
  live.release();
  EXPECT_FALSE(live.grabbed());
  EXPECT_EQ(live.sim().cloths()[0]->state().inv_mass[corner], inv_mass);
  // Pinned vertices are not grabbed: the pins own them.
  int pinned = -1;
  for (int i = 0; i < static_cast<int>(s0.x.size()); ++i)
    if (live.sim().cloths()[0]->state().inv_mass[i] == 0.0) pinned = i;
  ASSERT_GE(pinned, 0);
  const Vec3 q = live.sim().cloths()[0]->state().x[pinned];
  EXPECT_FALSE(live.grab(q + Vec3(0.001, 1.0, 0.001), Vec3(0, -1, 0)));
}

INSTANTIATE_TEST_SUITE_P(Solvers, LiveSceneDrag, ::testing::Values("symplectic_euler", "implicit_euler"));

#ifdef LOOM_HAVE_BULLET
scene::Scene trampoline(std::vector<std::string> sets = {}) {
  sets.push_back("cloths.0.mesh.nodes=[11, 11]");
  return scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/trampoline.json", sets);
}

TEST(LiveSceneBullet, BodiesSceneStepsInABulletWorldWithTheBoxMoving) {
  LiveScene live(trampoline());
  ASSERT_NE(live.bullet(), nullptr);
  ASSERT_EQ(live.colliders().size(), 1u);
  EXPECT_EQ(live.colliders()[0].name, "box");
  const Vec3 p0 = live.bullet()->body_position(0);
  EXPECT_NEAR(p0.y(), 1.0, 1e-6);
  for (int f = 0; f < 10; ++f) EXPECT_TRUE(live.step_frame().finite);
  EXPECT_EQ(live.frame(), 10);
  EXPECT_NEAR(live.time(), 10.0 / 60.0, 1e-12);
  const Vec3 p1 = live.bullet()->body_position(0);
  // Thrown down at 2 m/s under gravity: about 0.47 m lower after 1/6 s, onto the sheet at y = 0.5.
  EXPECT_LT(p1.y(), p0.y() - 0.2);
  // The drawn collider is the body at its pose now.
  EXPECT_LT((live.colliders()[0].curr.translation() - p1).norm(), 1e-6);
  // Rebuilding (an edit) starts the Bullet world again from the scene's start.
  live.materials()[0].areal_density *= 2.0;
  live.rebuild();
  EXPECT_EQ(live.frame(), 0);
  EXPECT_NEAR(live.bullet()->body_position(0).y(), 1.0, 1e-6);
  live.step_frame();
  EXPECT_EQ(live.frame(), 1);
}

TEST(LiveSceneBullet, PickGoesThroughBulletClothRayTestAndDragsTheVertex) {
  LiveScene live(trampoline());
  for (int f = 0; f < 5; ++f) live.step_frame();
  const cloth::Cloth& cl = *live.sim().cloths()[0];
  // A known cloth point: weights (0.6, 0.3, 0.1) on a triangle near a free corner region, away from the box.
  int tri = -1;
  for (int t = 0; t < static_cast<int>(cl.mesh().triangles().size()); ++t) {
    const auto& T = cl.mesh().triangles()[t];
    const Vec3 c = (cl.state().x[T[0]] + cl.state().x[T[1]] + cl.state().x[T[2]]) / 3.0;
    if (c.x() > 0.2 && c.x() < 0.35 && c.z() > 0.2 && c.z() < 0.35 && cl.state().inv_mass[T[0]] > 0) {
      tri = t;
      break;
    }
  }
  ASSERT_GE(tri, 0);
  const auto& T = cl.mesh().triangles()[tri];
  const Vec3 point = 0.6 * cl.state().x[T[0]] + 0.3 * cl.state().x[T[1]] + 0.1 * cl.state().x[T[2]];
  const Vec3 origin = point + Vec3(0.15, 1.5, 0.1), dir = point - origin;
  const Vec3 far = origin + 3.0 * dir;
  const bullet::RayHit by_bullet = live.bullet()->cloth().ray_test(origin, far);
  const bullet::RayHit brute = bullet::ray_triangles(cl.mesh(), cl.state().x, origin, far);
  ASSERT_TRUE(by_bullet.hit);
  EXPECT_EQ(by_bullet.triangle, tri);
  EXPECT_EQ(brute.triangle, tri);

  const double inv_mass = cl.state().inv_mass[T[0]];
  EXPECT_GT(inv_mass, 0.0);
  EXPECT_FALSE(live.grab(origin + Vec3(5, 0, 0), dir));  // misses the sheet
  ASSERT_TRUE(live.grab(origin, dir));
  const Grab g = *live.grabbed();
  EXPECT_EQ(g.cloth, by_bullet.cloth);
  EXPECT_EQ(g.triangle, by_bullet.triangle);
  EXPECT_LT((g.barycentric - by_bullet.barycentric).norm(), 1e-12);
  EXPECT_NEAR(g.distance, by_bullet.distance, 1e-9 * by_bullet.distance);
  EXPECT_NEAR(g.distance, dir.norm(), 1e-9);
  EXPECT_LT((g.barycentric - Vec3(0.6, 0.3, 0.1)).norm(), 1e-9);
  EXPECT_EQ(g.vertex, T[0]);  // the corner with the largest weight
  EXPECT_EQ(live.sim().cloths()[0]->state().inv_mass[g.vertex], 0.0);

  // Dragged up over two frames in the Bullet world: at the target after each frame.
  const Vec3 p = cl.state().x[g.vertex];
  for (const Vec3& target : {Vec3(p + Vec3(0.0, 0.2, 0.0)), Vec3(p + Vec3(0.05, 0.35, 0.0))}) {
    live.drag_to(target);
    live.step_frame();
    EXPECT_LT((live.sim().cloths()[0]->state().x[g.vertex] - target).norm(), 1e-9);
  }
  live.release();
  EXPECT_EQ(live.sim().cloths()[0]->state().inv_mass[g.vertex], inv_mass);
}

TEST(LiveSceneBullet, BodiesWithCollidersAreRefusedNamingTheField) {
  try {
    LiveScene live(
        trampoline({"colliders=[{\"name\": \"ball\", \"shape\": \"sphere\", \"radius\": 0.1, \"position\": "
                    "[0, 2, 0]}]"}));
    FAIL() << "accepted a scene with both bodies and colliders";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("trampoline.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("colliders"), std::string::npos) << e.what();
  }
}
#endif

}  // namespace
}  // namespace loom::viewer
