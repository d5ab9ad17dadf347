// Feature contacts (collision/FeatureContact.h) in a Bullet world: collider corners and edges against cloth
// triangles, and the two-way coupling's momentum balance with them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "BulletTestWorld.h"
#include "loom/collision/FeatureContact.h"

namespace loom::test {
namespace {

bullet::BulletClothSettings feature_settings(int cloth_substeps) {
  bullet::BulletClothSettings s = setup_tier();
  s.fixed_dt = 1.0 / 240.0;
  s.cloth_substeps = cloth_substeps;
  s.thickness = 0.005;
  s.contacts = bullet::BulletClothSettings::Contacts::features;
  return s;
}

Vec3 momentum(const bullet::BulletCloth& c) {
  Vec3 p = Vec3::Zero();
  for (const auto& cl : c.simulation().cloths())
    for (int i = 0; i < cl->state().size(); ++i) p += cl->state().mass[i] * cl->state().v[i];
  return p;
}

enum class Body { box_corner, capsule_end };

struct DropRun {
  double lowest = HUGE_VAL;  // m, the body centre's lowest height over the run
  int frames_under = 0;      // frames ending with the body's centre under the cloth (ray_test)
};

// A small body falls at 1 m/s onto the middle of one triangle of a coarse sheet (3 x 3 nodes, 0.3 m legs,
// pinned at its corners): a 6 cm box corner-first, or a capsule (2 cm radius, 12 cm long) end-first. Every
// cloth vertex stays far outside the body, so only the body's corner or end against the triangle can hold
// it. After every frame the body's centre must be over the cloth: a ray from it straight down meets the
// cloth and one straight up does not (bullet::BulletCloth::ray_test).
DropRun drop_on_triangle(Body body, const bullet::BulletClothSettings& s) {
  TestWorld w;
  cloth::SimulationSetup setup = sheet(3, 0.6, Vec3(-0.3, 1.0, -0.3));
  for (int v : {0, 2, 6, 8}) {
    cloth::PinSpec p;
    p.vertex = v;
    setup.cloths[0].pins.push_back(p);
  }
  const cloth::ClothMesh& mesh = *setup.cloths[0].mesh;
  const cloth::Tri& t = mesh.triangles()[0];
  const Vec3 centroid =
      (mesh.rest_positions()[t[0]] + mesh.rest_positions()[t[1]] + mesh.rest_positions()[t[2]]) / 3.0;
  btRigidBody* rb = nullptr;
  if (body == Body::box_corner) {
    rb = w.add_body(new btBoxShape(btVector3(0.03, 0.03, 0.03)), 0.5, centroid + Vec3(0, 0.12, 0));
    // Corner down: the diagonal (1, 1, 1) turned onto -y.
    btTransform tf = rb->getWorldTransform();
    const Eigen::Quaterniond q =
        Eigen::Quaterniond::FromTwoVectors(Vec3(1, 1, 1).normalized(), Vec3(0, -1, 0));
    tf.setRotation(btQuaternion(q.x(), q.y(), q.z(), q.w()));
    rb->setWorldTransform(tf);
    rb->getMotionState()->setWorldTransform(tf);
  } else {
    // Axis along y: the lower hemisphere's pole 6 cm under the centre.
    rb = w.add_body(new btCapsuleShape(0.02, 0.08), 0.3, centroid + Vec3(0, 0.12, 0));
  }
  rb->setLinearVelocity(btVector3(0, -1, 0));
  bullet::BulletCloth* c = w.add_cloth(setup, s);
  DropRun r;
  for (int f = 0; f < 90; ++f) {
    w.frame();
    const Vec3 x = eig(rb->getCenterOfMassPosition());
    r.lowest = std::min(r.lowest, x.y());
    const bool over = c->ray_test(x, x - Vec3(0, 10, 0)).hit && !c->ray_test(x, x + Vec3(0, 10, 0)).hit;
    if (!over) ++r.frames_under;
  }
  if (std::getenv("LOOM_DIAG"))
    for (const cloth::StageProfile& p : c->simulation().profile()) {
      std::printf("  %-28s", p.name.c_str());
      for (const auto& [k, v] : p.counters) std::printf(" %s=%.0f", k.c_str(), v);
      std::printf("\n");
    }
  return r;
}

bullet::BulletClothSettings drop_settings(bullet::BulletClothSettings::Tier tier) {
  bullet::BulletClothSettings s = feature_settings(2);
  s.contacts = bullet::BulletClothSettings{}.contacts;  // the default
  s.tier = tier;
  return s;
}

TEST(FeatureContact, SetupTierDefaultIsFeatureContacts) {
  EXPECT_EQ(bullet::BulletClothSettings{}.contacts, bullet::BulletClothSettings::Contacts::features);
  TestWorld w;
  bullet::BulletCloth* c = w.add_cloth(sheet(3, 0.6, Vec3(-0.3, 1.0, -0.3)), setup_tier());
  const std::vector<std::string> names = c->simulation().stage_names();
  EXPECT_NE(std::find(names.begin(), names.end(), "feature_contact"), names.end());
}

// The setup tier's default contacts (Contacts::features) hold a box corner and a capsule end on the triangle.
TEST(FeatureContact, SetupTierHoldsBoxCornerOnTriangle) {
  const DropRun r =
      drop_on_triangle(Body::box_corner, drop_settings(bullet::BulletClothSettings::Tier::setup));
  std::printf("setup tier, box corner: centre lowest %.4f m, %d frames under the cloth\n", r.lowest,
              r.frames_under);
  EXPECT_EQ(r.frames_under, 0);
  EXPECT_GT(r.lowest, 0.5);  // held by the sheet (at 1.0 m), not fallen through it
}

TEST(FeatureContact, SetupTierHoldsCapsuleEndOnTriangle) {
  const DropRun r =
      drop_on_triangle(Body::capsule_end, drop_settings(bullet::BulletClothSettings::Tier::setup));
  std::printf("setup tier, capsule end: centre lowest %.4f m, %d frames under the cloth\n", r.lowest,
              r.frames_under);
  EXPECT_EQ(r.frames_under, 0);
  EXPECT_GT(r.lowest, 0.5);
}

// The coupled real-time tier (BodyCoupling.h: body features against triangles, mass-aware, inelastic)
// likewise.
TEST(FeatureContact, CoupledTierHoldsBoxCornerOnTriangle) {
  const DropRun r =
      drop_on_triangle(Body::box_corner, drop_settings(bullet::BulletClothSettings::Tier::realtime));
  std::printf("coupled tier, box corner: centre lowest %.4f m, %d frames under the cloth\n", r.lowest,
              r.frames_under);
  EXPECT_EQ(r.frames_under, 0);
  EXPECT_GT(r.lowest, 0.5);
}

TEST(FeatureContact, CoupledTierHoldsCapsuleEndOnTriangle) {
  const DropRun r =
      drop_on_triangle(Body::capsule_end, drop_settings(bullet::BulletClothSettings::Tier::realtime));
  std::printf("coupled tier, capsule end: centre lowest %.4f m, %d frames under the cloth\n", r.lowest,
              r.frames_under);
  EXPECT_EQ(r.frames_under, 0);
  EXPECT_GT(r.lowest, 0.5);
}

// Control: vertex-only contacts (Contacts::vertex, the face phase off) let the same corner and end through,
// so the checks above can fail.
TEST(FeatureContact, BoxCornerAndCapsuleEndFallThroughWithVertexContacts) {
  bullet::BulletClothSettings s = drop_settings(bullet::BulletClothSettings::Tier::setup);
  s.contacts = bullet::BulletClothSettings::Contacts::vertex;
  for (Body b : {Body::box_corner, Body::capsule_end}) {
    const DropRun r = drop_on_triangle(b, s);
    std::printf("vertex contacts: centre lowest %.4f m, %d frames under the cloth\n", r.lowest,
                r.frames_under);
    EXPECT_GT(r.frames_under, 0);
    EXPECT_LT(r.lowest, 0.5);
  }
}

// Free cloth + free rigid box, no gravity: total linear momentum is conserved through the face contacts.
TEST(FeatureContact, MomentumConservedFreeClothFreeBox) {
  TestWorld w(Vec3::Zero());
  btRigidBody* box = w.add_body(new btBoxShape(btVector3(0.04, 0.04, 0.04)), 0.5, Vec3(0.01, 0.3, 0.02));
  btTransform tf = box->getWorldTransform();
  tf.setRotation(btQuaternion(btVector3(1, 0, 1).normalized(), btScalar(0.9)));
  box->setWorldTransform(tf);
  box->getMotionState()->setWorldTransform(tf);
  box->setLinearVelocity(btVector3(0, -3, 0));
  bullet::BulletCloth* c =
      w.add_cloth(sheet(5, 0.5, Vec3(-0.25, 0.0, -0.25), Vec3::Zero()), feature_settings(4));
  const Vec3 p0 = 0.5 * eig(box->getLinearVelocity()) + momentum(*c);
  double max_rel = 0.0;
  for (int f = 0; f < 18; ++f) {
    w.frame();
    const Vec3 p = (1.0 / box->getInvMass()) * eig(box->getLinearVelocity()) + momentum(*c);
    max_rel = std::max(max_rel, (p - p0).norm() / p0.norm());
  }
  EXPECT_LT(momentum(*c).y(), -0.05);  // the impact happened
  EXPECT_LT(max_rel, 1e-6);
  std::printf("feature contacts momentum: max relative error %.3g\n", max_rel);
}

// The features each collider type gives the face phase.
TEST(FeatureContact, ColliderFeatures) {
  collision::Collider c;
  c.shape.type = collision::ShapeType::box;
  c.shape.half_extents = Vec3(0.1, 0.2, 0.3);
  collision::ColliderFeatures f = collision::collider_features(c);
  ASSERT_EQ(f.a.size(), 12u);
  double length = 0.0;
  for (size_t k = 0; k < f.a.size(); ++k) length += (f.b[k] - f.a[k]).norm();
  EXPECT_NEAR(length, 4 * (0.2 + 0.4 + 0.6), 1e-12);
  c.shape.type = collision::ShapeType::capsule;
  c.shape.radius = 0.05;
  c.shape.half_height = 0.1;
  f = collision::collider_features(c);
  ASSERT_EQ(f.a.size(), 1u);
  EXPECT_DOUBLE_EQ(f.radius, 0.05);
  EXPECT_NEAR((f.b[0] - f.a[0]).norm(), 0.2, 1e-12);
  c.shape.type = collision::ShapeType::plane;
  EXPECT_TRUE(collision::collider_features(c).a.empty());
}

}  // namespace
}  // namespace loom::test
