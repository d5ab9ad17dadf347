// GarmentInstance::set_colliders: external colliders (a game's shapes, a Bullet world's bodies) in the
// garment's fixed step, without Bullet.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "TestCape.h"
#include "loom/characters/GarmentInstance.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Error.h"

using namespace loom::characters;
using loom::cloth::Vec3;
using loom::cloth::Vec3s;
using loom::collision::Collider;
using loom::collision::ColliderSet;
using loom::collision::ShapeType;
using Iso = Eigen::Isometry3d;

namespace {

using Cape = loom::test::TestCape;

Cape make_cape() { return loom::test::make_test_cape({11, 13, -1.0, false, 0.05}); }

// A 10 cm ball that sweeps through the cape's lower half along +z at 0.5 m/s from t = 0.2 s (centre z =
// -0.45 -> +0.15, at y = 1.15).
Collider moving_ball() {
  Collider ball;
  ball.name = "ball";
  ball.shape.type = ShapeType::sphere;
  ball.shape.radius = 0.1;
  ball.motion = [](double t) {
    Iso p = Iso::Identity();
    p.translation() = Vec3(0.0, 1.15, -0.45 + 0.5 * std::clamp(t - 0.2, 0.0, 1.2));
    return p;
  };
  return ball;
}

}  // namespace

TEST(GarmentColliders, MovingBallPushesTheCapeAndFeelsItsReaction) {
  const Cape c = make_cape();
  GarmentInstance free(c.bind, c.tris, c.skin, c.settings, c.bind_pose, "cape");
  GarmentInstance hit(c.bind, c.tris, c.skin, c.settings, c.bind_pose, "cape");
  auto set = std::make_shared<ColliderSet>(ColliderSet{moving_ball()});
  loom::collision::RealtimeContactSettings contact;
  contact.thickness = 0.005;
  hit.set_colliders(set, contact);
  double min_gap = HUGE_VAL, pushed = 0.0;
  for (int f = 1; f <= 90; ++f) {  // 1.5 s
    for (GarmentInstance* g : {&free, &hit}) {
      g->set_pose(c.bind_pose);
      g->step(1.0 / 60.0);
    }
    const Vec3 centre = set->front().motion(hit.time()).translation();
    for (int i = 0; i < hit.num_vertices(); ++i) {
      ASSERT_TRUE(hit.positions()[i].allFinite());
      min_gap = std::min(min_gap, (hit.positions()[i] - centre).norm() - 0.1);
      pushed = std::max(pushed, hit.positions()[i].z() - free.positions()[i].z());
      if (c.settings.constraints.max_distance[i] == 0.0) {  // kinematic: on the skinned mesh, never pushed
        EXPECT_LE((hit.positions()[i] - hit.skinned()[i]).norm(), 1e-9);
      }
    }
  }
  EXPECT_GT(min_gap, 0.005 - 1e-9);  // every vertex at least the thickness off the ball at every frame end
  EXPECT_GT(pushed, 0.05);           // the ball carried the cape forward (+z)
  // The cape pushed back: the ball's summed reaction points against its motion (-z).
  EXPECT_LT(set->front().reaction_impulse.z(), 0.0);
}

TEST(GarmentColliders, CollidersFarAwayChangeNothingAndNullRemovesThem) {
  const Cape c = make_cape();
  GarmentInstance a(c.bind, c.tris, c.skin, c.settings, c.bind_pose, "cape");
  GarmentInstance b(c.bind, c.tris, c.skin, c.settings, c.bind_pose, "cape");
  Collider far;
  far.name = "far";
  far.shape.type = ShapeType::sphere;
  far.shape.radius = 0.1;
  far.prev.translation() = far.curr.translation() = Vec3(5, 0, 0);
  b.set_colliders(std::make_shared<ColliderSet>(ColliderSet{far}));
  for (int f = 0; f < 30; ++f)
    for (GarmentInstance* g : {&a, &b}) {
      if (f == 15 && g == &b) g->set_colliders(nullptr);
      g->set_pose(c.bind_pose);
      g->step(1.0 / 60.0);
    }
  EXPECT_EQ(b.colliders(), nullptr);
  for (int i = 0; i < a.num_vertices(); ++i) EXPECT_EQ(a.positions()[i], b.positions()[i]);
}

TEST(GarmentColliders, BadContactSettingsNameTheField) {
  const Cape c = make_cape();
  GarmentInstance g(c.bind, c.tris, c.skin, c.settings, c.bind_pose, "cape");
  auto message = [&](const loom::collision::RealtimeContactSettings& s) -> std::string {
    try {
      g.set_colliders(std::make_shared<ColliderSet>(), s);
    } catch (const loom::Error& e) {
      return e.what();
    }
    return "";
  };
  loom::collision::RealtimeContactSettings s;
  s.thickness = -0.001;
  EXPECT_NE(message(s).find("cape: contact.thickness"), std::string::npos) << message(s);
  s.thickness = HUGE_VAL;
  EXPECT_NE(message(s).find("contact.thickness"), std::string::npos) << message(s);
  s = {};
  s.passes = 0;
  EXPECT_NE(message(s).find("contact.passes"), std::string::npos) << message(s);
}
