// BulletGarment: a character's skinned garment (GarmentInstance) colliding with a Bullet world's bodies
// (BulletColliders): a static wall (box and triangle mesh), a dynamic crate pushed by the cape, wake-up of a
// sleeping cape by a moving body, bad settings.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "../characters/TestCape.h"
#include "BulletTestWorld.h"
#include "loom/bullet/BulletGarment.h"
#include "loom/characters/GarmentInstance.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Error.h"

using loom::Error;
using loom::bullet::BulletGarment;
using loom::bullet::BulletGarmentSettings;
using loom::characters::Affine;
using loom::characters::GarmentInstance;
using loom::characters::GarmentSettings;
using loom::characters::Skin;
using loom::cloth::Vec3;
using loom::cloth::Vec3s;
using loom::test::bt;
using loom::test::eig;
using loom::test::TestWorld;
using Iso = Eigen::Isometry3d;

namespace {

constexpr double kThickness = 0.005;  // m, the contact offset of these tests
constexpr double kFrame = 1.0 / 60.0;

using Cape = loom::test::TestCape;

Cape make_cape() { return loom::test::make_test_cape({11, 13, -1.0, true, 0.05}); }

std::vector<Affine> pose_at(const Cape& c, const Iso& frame) {
  return {frame * c.bind_pose[0], frame * c.bind_pose[1]};
}

// The character walks to and fro along x (parallel to the wall) and turns about y by up to 0.6 rad, which
// swings the cape's side edges 11 cm back (towards -z) and forth.
Iso clip_frame(double t) {
  Iso f = Iso::Identity();
  f.translate(Vec3(0.3 * std::sin(2 * M_PI * 0.25 * t), 0, 0));
  f.rotate(Eigen::AngleAxisd(0.6 * std::sin(2 * M_PI * 0.5 * t), Vec3::UnitY()));
  return f;
}

// Signed distance (m) of p from an axis-aligned box (centre c, half extents e); negative inside.
double box_distance(const Vec3& p, const Vec3& c, const Vec3& e) {
  const Vec3 q = (p - c).cwiseAbs() - e;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// The wall behind the character: front face at z = -0.2 (5 cm behind the cape), top at y = 1.25, 4 m long.
const Vec3 kWallCentre(0.0, 0.625, -0.3), kWallHalf(2.0, 0.625, 0.1);

btCollisionShape* box_mesh(const Vec3& half) {
  // The 12 triangles of the box as a static triangle mesh (btBvhTriangleMeshShape).
  auto* mesh = new btTriangleMesh();
  const Vec3 h = half;
  auto corner = [&](int k) {
    return bt(Vec3((k & 1 ? 1 : -1) * h.x(), (k & 2 ? 1 : -1) * h.y(), (k & 4 ? 1 : -1) * h.z()));
  };
  const int faces[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1},
                           {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  for (const auto& f : faces) {
    mesh->addTriangle(corner(f[0]), corner(f[1]), corner(f[2]));
    mesh->addTriangle(corner(f[0]), corner(f[2]), corner(f[3]));
  }
  static std::vector<std::unique_ptr<btTriangleMesh>> keep;  // the shape references the mesh
  keep.emplace_back(mesh);
  return new btBvhTriangleMeshShape(mesh, true);
}

struct ClipResult {
  std::vector<Vec3s> frames;  // positions() at every frame end
  double min_wall_distance = HUGE_VAL;
  bool finite = true;
};

enum class Wall { none, box, mesh };

// 3 s of the clip at 60 Hz in a world holding the wall (or nothing), the garment stepped by BulletGarment.
ClipResult play_clip(Wall wall) {
  TestWorld w;
  if (wall == Wall::box) w.add_body(new btBoxShape(bt(kWallHalf)), 0.0, kWallCentre);
  if (wall == Wall::mesh) w.add_body(box_mesh(kWallHalf), 0.0, kWallCentre);
  Cape c = make_cape();
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, clip_frame(0)), "cape");
  BulletGarmentSettings s;
  s.contact.thickness = kThickness;
  BulletGarment bg(g, &w.world, s);
  ClipResult r;
  for (int f = 1; f <= 180; ++f) {
    w.frame(kFrame);
    g.set_pose(pose_at(c, clip_frame(f * kFrame)));
    bg.step(kFrame);
    r.frames.push_back(g.positions());
    for (const Vec3& p : g.positions()) {
      r.finite = r.finite && p.allFinite();
      r.min_wall_distance = std::min(r.min_wall_distance, box_distance(p, kWallCentre, kWallHalf));
    }
  }
  return r;
}

double max_difference(const std::vector<Vec3s>& a, const std::vector<Vec3s>& b) {
  double d = 0.0;
  for (size_t f = 0; f < a.size(); ++f)
    for (size_t i = 0; i < a[f].size(); ++i) d = std::max(d, (a[f][i] - b[f][i]).norm());
  return d;
}

}  // namespace

TEST(BulletGarment, CapeBrushingAWallStaysOutsideAndIsDeflected) {
  const ClipResult free = play_clip(Wall::none);
  const ClipResult box = play_clip(Wall::box);
  const ClipResult mesh = play_clip(Wall::mesh);
  ASSERT_TRUE(free.finite && box.finite && mesh.finite);
  // Without the wall the swinging cape goes well into where the wall stands: the test has contact to check.
  EXPECT_LT(free.min_wall_distance, -0.03);
  // With it (box or static triangle mesh), no vertex is inside deeper than the thickness at a frame end.
  EXPECT_GT(box.min_wall_distance, -kThickness);
  EXPECT_GT(mesh.min_wall_distance, -kThickness);
  // The wall deflects the cape.
  EXPECT_GT(max_difference(free.frames, box.frames), 0.03);
  EXPECT_GT(max_difference(free.frames, mesh.frames), 0.03);
  std::printf("min wall distance: free %.4f box %.4f mesh %.4f m; deflection box %.4f mesh %.4f m\n",
              free.min_wall_distance, box.min_wall_distance, mesh.min_wall_distance,
              max_difference(free.frames, box.frames), max_difference(free.frames, mesh.frames));
}

namespace {

// A 0.05 kg crate (8 cm cube) on a frictionless static shelf, where the cape's swinging edge reaches it.
const Vec3 kCrateHalf(0.04, 0.04, 0.04), kCrateStart(0.12, 1.06, -0.27);
const Vec3 kShelfCentre(0.12, 0.51, -0.4), kShelfHalf(0.3, 0.51, 0.2);  // top at y = 1.02, front z = -0.2

struct CrateResult {
  Vec3 displacement = Vec3::Zero();  // m, the crate's
  Vec3 momentum = Vec3::Zero();      // kg m/s, the crate's at the end
  Vec3 applied = Vec3::Zero();       // N s, what the bridge gave it
  double min_distance = HUGE_VAL;    // m, of the cape's vertices to the crate, at frame ends
  bool finite = true;
};

CrateResult play_crate(bool reactions) {
  TestWorld w;
  btRigidBody* shelf = w.add_body(new btBoxShape(bt(kShelfHalf)), 0.0, kShelfCentre);
  btRigidBody* crate = w.add_body(new btBoxShape(bt(kCrateHalf)), 0.05, kCrateStart);
  shelf->setFriction(0);
  crate->setFriction(0);
  crate->setActivationState(DISABLE_DEACTIVATION);
  Cape c = make_cape();
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, clip_frame(0)), "cape");
  BulletGarmentSettings s;
  s.contact.thickness = kThickness;
  s.bodies.reactions = reactions;
  BulletGarment bg(g, &w.world, s);
  CrateResult r;
  for (int f = 1; f <= 90; ++f) {
    w.frame(kFrame);
    g.set_pose(pose_at(c, clip_frame(f * kFrame)));
    bg.step(kFrame);
    const btTransform& tf = crate->getWorldTransform();
    for (const Vec3& p : g.positions()) {
      r.finite = r.finite && p.allFinite();
      // The crate's frame: rotate p into it (the box distance in its frame).
      const Vec3 local = eig(tf.inverse()(bt(p)));
      r.min_distance = std::min(r.min_distance, box_distance(local, Vec3::Zero(), kCrateHalf));
    }
  }
  r.displacement = eig(crate->getWorldTransform().getOrigin()) - kCrateStart;
  r.momentum = 0.05 * eig(crate->getLinearVelocity());
  r.applied = bg.bodies().applied_impulse(crate);
  return r;
}

}  // namespace

TEST(BulletGarment, CapePushesADynamicCrateWithItsReaction) {
  const CrateResult on = play_crate(true);
  const CrateResult off = play_crate(false);
  ASSERT_TRUE(on.finite && off.finite);
  std::printf("crate moved %.4f m (reactions on), %.6f m (off); min distance %.4f / %.4f m; applied %g N s\n",
              Vec3(on.displacement.x(), 0, on.displacement.z()).norm(),
              Vec3(off.displacement.x(), 0, off.displacement.z()).norm(), on.min_distance, off.min_distance,
              on.applied.norm());
  // The cape pushes the crate back (-z) off its place; without reactions the crate does not feel it.
  EXPECT_LT(on.displacement.z(), -0.01);
  EXPECT_LT(Vec3(off.displacement.x(), 0, off.displacement.z()).norm(), 1e-3);
  EXPECT_EQ(off.applied, Vec3::Zero());
  // On a frictionless shelf the crate's horizontal momentum is the horizontal impulse the bridge applied.
  EXPECT_NEAR(on.momentum.x(), on.applied.x(), 1e-4 * on.applied.norm() + 1e-9);
  EXPECT_NEAR(on.momentum.z(), on.applied.z(), 1e-4 * on.applied.norm() + 1e-9);
  // Dynamic or not, the crate keeps the cape out to the thickness at frame ends.
  EXPECT_GT(on.min_distance, -kThickness);
  EXPECT_GT(off.min_distance, -kThickness);
}

TEST(BulletGarment, MovingBodyWakesASleepingCapeAStaticOneDoesNot) {
  TestWorld w;
  // A static box pressed 1 cm into the cape's lower corner and a kinematic box 35 cm behind the cape.
  w.add_body(new btBoxShape(btVector3(0.1, 0.1, 0.05)), 0.0, Vec3(0.2, 1.1, -0.19));
  const Vec3 start(0.0, 1.1, -0.6);
  btRigidBody* mover = w.add_body(new btBoxShape(btVector3(0.1, 0.1, 0.1)), 0.0, start, true);
  Cape c = make_cape();
  c.settings.sleep.enabled = true;
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, Iso::Identity()), "cape");
  BulletGarmentSettings s;
  s.contact.thickness = kThickness;
  BulletGarment bg(g, &w.world, s);
  auto frame = [&](const Vec3& mover_at) {
    btTransform tf;
    tf.setIdentity();
    tf.setOrigin(bt(mover_at));
    mover->getMotionState()->setWorldTransform(tf);
    w.frame(kFrame);
    g.set_pose(pose_at(c, Iso::Identity()));
    bg.step(kFrame);
  };
  for (int f = 0; f < 600 && !g.asleep(); ++f) frame(start);
  ASSERT_TRUE(g.asleep());  // the static box near it does not keep it awake
  const Vec3s rest = g.positions();
  const long solver = g.solver_steps();
  for (int f = 0; f < 30; ++f) frame(start);
  EXPECT_TRUE(g.asleep());  // a body that does not move wakes nothing
  EXPECT_EQ(g.solver_steps(), solver);
  // The mover comes at 0.3 m/s along +z: its box reaches the cape's (z = -0.15) after about 1 s.
  double wake_z = HUGE_VAL;         // m, the mover's centre when the cape woke
  Vec3 lo = rest[0], hi = rest[0];  // the sleeping cape's box
  for (const Vec3& p : rest) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  double min_distance = HUGE_VAL, moved = 0.0;
  Vec3 at = start;
  for (int f = 0; f < 90; ++f) {
    at.z() = std::min(at.z() + 0.3 * kFrame, -0.2);
    frame(at);
    if (wake_z == HUGE_VAL) {  // asleep before: awake exactly when the mover's box meets the cape's
      btVector3 a, b;
      mover->getAabb(a, b);
      const bool touches = (eig(a).array() <= hi.array()).all() && (lo.array() <= eig(b).array()).all();
      EXPECT_EQ(g.asleep(), !touches) << "mover at z = " << at.z();
      if (!g.asleep()) wake_z = at.z();
    }
    for (size_t i = 0; i < rest.size(); ++i) {
      moved = std::max(moved, (g.positions()[i] - rest[i]).norm());
      min_distance = std::min(min_distance, box_distance(g.positions()[i], at, Vec3(0.1, 0.1, 0.1)));
    }
  }
  // It woke when the mover's box (front face at z + 0.1) reached the cape's box (about z = -0.15).
  EXPECT_GE(wake_z, -0.28);
  EXPECT_LE(wake_z, -0.2);
  EXPECT_GT(moved, 0.02);  // pushed by the mover
  EXPECT_GT(min_distance, -kThickness);
}

TEST(BulletGarment, BadSettingsNameTheField) {
  TestWorld w;
  Cape c = make_cape();
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, pose_at(c, Iso::Identity()), "cape");
  auto message = [&](const BulletGarmentSettings& s) -> std::string {
    try {
      BulletGarment bg(g, &w.world, s);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  BulletGarmentSettings s;
  s.bodies.query_margin = -1;
  EXPECT_NE(message(s).find("query_margin"), std::string::npos) << message(s);
  s = {};
  s.bodies.static_friction = 0.1;  // below friction 0.3
  EXPECT_NE(message(s).find("static_friction"), std::string::npos) << message(s);
  s = {};
  s.contact.thickness = std::nan("");
  EXPECT_NE(message(s).find("contact.thickness"), std::string::npos) << message(s);
  s = {};
  s.contact.passes = 0;
  EXPECT_NE(message(s).find("contact.passes"), std::string::npos) << message(s);
  s = {};
  s.wake_distance = -0.1;
  EXPECT_NE(message(s).find("wake_distance"), std::string::npos) << message(s);
  BulletGarment bg(g, &w.world);
  try {
    bg.step(-1.0);
    ADD_FAILURE() << "no error for a negative frame_dt";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame_dt"), std::string::npos) << e.what();
  }
  EXPECT_THROW(loom::bullet::BulletColliders(nullptr), Error);
}
