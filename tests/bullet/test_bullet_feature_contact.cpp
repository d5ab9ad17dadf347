// Feature contacts (collision/FeatureContact.h) in a Bullet world: collider corners and edges against cloth
// triangles, and the two-way coupling's momentum balance with them.
#include <gtest/gtest.h>

#include <cmath>

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

// A 6 cm box falls corner-first onto the middle of one triangle of a coarse sheet (3 x 3 nodes, 0.3 m legs,
// pinned at its corners): every cloth vertex stays far outside the box, so only the corner against the
// triangle can hold it. Returns the box centre's lowest height over the run (m).
double corner_first_drop(bullet::BulletClothSettings::Contacts contacts, double* cloth_min_y) {
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
  // Corner down: the diagonal (1, 1, 1) turned onto -y.
  btBoxShape* shape = new btBoxShape(btVector3(0.03, 0.03, 0.03));
  btRigidBody* box = w.add_body(shape, 0.5, centroid + Vec3(0, 0.12, 0));
  btTransform tf = box->getWorldTransform();
  const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(Vec3(1, 1, 1).normalized(), Vec3(0, -1, 0));
  tf.setRotation(btQuaternion(q.x(), q.y(), q.z(), q.w()));
  box->setWorldTransform(tf);
  box->getMotionState()->setWorldTransform(tf);
  box->setLinearVelocity(btVector3(0, -1, 0));
  bullet::BulletClothSettings s = feature_settings(2);
  s.contacts = contacts;
  bullet::BulletCloth* c = w.add_cloth(setup, s);
  double lowest = HUGE_VAL;
  *cloth_min_y = HUGE_VAL;
  for (int f = 0; f < 90; ++f) {
    w.frame();
    lowest = std::min(lowest, double(box->getCenterOfMassPosition().y()));
    for (const Vec3& x : c->simulation().cloths()[0]->state().x) *cloth_min_y = std::min(*cloth_min_y, x.y());
  }
  return lowest;
}

TEST(FeatureContact, CornerFirstBoxStaysOnTriangle) {
  double cloth_low = 0.0;
  const double lowest = corner_first_drop(bullet::BulletClothSettings::Contacts::features, &cloth_low);
  std::printf("features: box centre lowest %.4f m, cloth lowest %.4f m\n", lowest, cloth_low);
  // The corner (0.052 m below the centre) rests on the sagging triangle: the centre stays above the
  // cloth's lowest point by at least the corner's depth.
  EXPECT_GT(lowest, cloth_low + 0.04);
  EXPECT_GT(lowest, 0.5);  // held by the sheet, not fallen through it
}

// Control: vertex-only contacts (the bridge's ContactStage, edges included) let the same corner through.
TEST(FeatureContact, CornerFirstBoxFallsThroughWithVertexContacts) {
  double cloth_low = 0.0;
  const double lowest = corner_first_drop(bullet::BulletClothSettings::Contacts::vertex, &cloth_low);
  std::printf("vertex contacts: box centre lowest %.4f m\n", lowest);
  EXPECT_LT(lowest, 0.5);
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
