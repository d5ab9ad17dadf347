// map_shape: every supported Bullet shape becomes the matching Loom collider with the body's
// transform — checked against Bullet's own support mapping in random directions — and unsupported shapes are
// reported once, by name.
#include <gtest/gtest.h>

#include <random>

#include "../../bullet_bridge/src/ShapeDistance.h"  // the bridge's signed distance (private header)
#include "BulletTestWorld.h"

namespace loom::test {
namespace {

using collision::Collider;
using collision::ShapeType;
using collision::Transform;

// max over the collider of d·p (m), d a world unit vector.
double loom_support(const Collider& c, const Vec3& d) {
  const Vec3 l = c.curr.linear().transpose() * d;
  const auto& s = c.shape;
  double h = 0.0;
  switch (s.type) {
    case ShapeType::sphere:
      h = s.radius;
      break;
    case ShapeType::capsule:
      h = s.half_height * std::abs(l.y()) + s.radius;
      break;
    case ShapeType::box:
      h = s.half_extents.dot(l.cwiseAbs());
      break;
    case ShapeType::cylinder:
      h = s.half_height * std::abs(l.y()) + s.radius * std::hypot(l.x(), l.z());
      break;
    case ShapeType::convex:
    case ShapeType::mesh: {
      h = -HUGE_VAL;
      for (const Vec3& v : s.vertices) h = std::max(h, v.dot(l));
      break;
    }
    default:
      ADD_FAILURE() << "no support for " << collision::shape_type_name(s.type);
  }
  return d.dot(c.curr.translation()) + h;
}

// Bullet's support of a convex shape placed at tf.
double bullet_support(const btConvexShape* s, const btTransform& tf, const Vec3& d) {
  const btVector3 l = tf.getBasis().transpose() * bt(d);
  return d.dot(eig(tf * s->localGetSupportingVertex(l)));
}

btTransform random_pose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  btQuaternion q(btScalar(u(rng)), btScalar(u(rng)), btScalar(u(rng)), btScalar(u(rng)) + 1.5);
  q.normalize();
  return btTransform(q, btVector3(btScalar(u(rng)), btScalar(u(rng)), btScalar(u(rng))));
}

Transform eig_tf(const btTransform& t) {
  Transform out = Transform::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.linear()(r, c) = t.getBasis()[r][c];
  out.translation() = eig(t.getOrigin());
  return out;
}

// Maps a convex shape at a random pose and compares supports in 200 directions.
void check_convex(btConvexShape* shape, ShapeType expected, double tol) {
  std::mt19937 rng(3);
  const btTransform tf = random_pose(rng);
  std::vector<Collider> out;
  std::vector<std::string> unsupported;
  bullet::map_shape(shape, eig_tf(tf), "b", out, unsupported);
  ASSERT_TRUE(unsupported.empty());
  ASSERT_EQ(out.size(), 1u) << shape->getName();
  EXPECT_EQ(out[0].shape.type, expected) << shape->getName();
  std::normal_distribution<double> n;
  double worst = 0.0;
  for (int k = 0; k < 200; ++k) {
    const Vec3 d = Vec3(n(rng), n(rng), n(rng)).normalized();
    worst = std::max(worst, std::abs(loom_support(out[0], d) - bullet_support(shape, tf, d)));
  }
  EXPECT_LT(worst, tol) << shape->getName();
}

TEST(BulletShapes, PrimitivesMatchBulletSupport) {
  const double tol = 1e-5;  // float btScalar
  btSphereShape sphere(0.3);
  check_convex(&sphere, ShapeType::sphere, tol);
  btCapsuleShape capy(0.1, 0.5);
  btCapsuleShapeX capx(0.1, 0.5);
  btCapsuleShapeZ capz(0.1, 0.5);
  check_convex(&capy, ShapeType::capsule, tol);
  check_convex(&capx, ShapeType::capsule, tol);
  check_convex(&capz, ShapeType::capsule, tol);
  // Shapes with a margin: Bullet rounds their corners by the margin; with margin 0 they are sharp.
  btBoxShape box(btVector3(0.2, 0.3, 0.4));
  box.setMargin(0);
  check_convex(&box, ShapeType::box, tol);
  btCylinderShape cy(btVector3(0.2, 0.3, 0.2));
  btCylinderShapeX cx(btVector3(0.3, 0.2, 0.2));
  btCylinderShapeZ cz(btVector3(0.2, 0.2, 0.3));
  for (btCylinderShape* c : std::initializer_list<btCylinderShape*>{&cy, &cx, &cz}) {
    c->setMargin(0);
    check_convex(c, ShapeType::cylinder, tol);
  }
  // The cone becomes a 64-gon pyramid: within r (1 - cos(pi/64)) of the true support.
  btConeShape coy(0.2, 0.5);
  btConeShapeX cox(0.2, 0.5);
  btConeShapeZ coz(0.2, 0.5);
  for (btConeShape* c : std::initializer_list<btConeShape*>{&coy, &cox, &coz}) {
    c->setMargin(0);
    check_convex(c, ShapeType::convex, 0.2 * (1 - std::cos(M_PI / 64)) + tol);
  }
  btConvexHullShape hull;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  for (int k = 0; k < 30; ++k)
    hull.addPoint(btVector3(btScalar(u(rng)), btScalar(u(rng)), btScalar(u(rng))), k == 29);
  hull.setLocalScaling(btVector3(1.0, 2.0, 0.5));
  hull.setMargin(0);
  check_convex(&hull, ShapeType::convex, tol);
}

TEST(BulletShapes, CompoundRecursive) {
  btCompoundShape outer, inner;
  btSphereShape sphere(0.1);
  btCapsuleShapeX capsule(0.05, 0.3);
  btBoxShape box(btVector3(0.1, 0.2, 0.3));
  box.setMargin(0);
  btTransform t1(btQuaternion(btVector3(0, 0, 1), 0.4), btVector3(0.5, 0, 0));
  btTransform t2(btQuaternion(btVector3(1, 0, 0), -0.3), btVector3(0, 0.2, 0.1));
  btTransform t3(btQuaternion(btVector3(0, 1, 0), 0.7), btVector3(-0.3, 0, 0));
  inner.addChildShape(t1, &sphere);
  inner.addChildShape(t2, &capsule);
  outer.addChildShape(t3, &inner);
  outer.addChildShape(btTransform::getIdentity(), &box);
  std::mt19937 rng(5);
  const btTransform tf = random_pose(rng);
  std::vector<Collider> out;
  std::vector<std::string> unsupported;
  bullet::map_shape(&outer, eig_tf(tf), "body", out, unsupported);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[0].shape.type, ShapeType::sphere);
  EXPECT_EQ(out[1].shape.type, ShapeType::capsule);
  EXPECT_EQ(out[2].shape.type, ShapeType::box);
  EXPECT_EQ(out[0].name.rfind("body/0/0:", 0), 0u) << out[0].name;
  EXPECT_EQ(out[1].name.rfind("body/0/1:", 0), 0u) << out[1].name;
  EXPECT_EQ(out[2].name.rfind("body/1:", 0), 0u) << out[2].name;
  const btTransform place[3] = {tf * t3 * t1, tf * t3 * t2, tf};
  const btConvexShape* shapes[3] = {&sphere, &capsule, &box};
  std::normal_distribution<double> n;
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 100; ++k) {
      const Vec3 d = Vec3(n(rng), n(rng), n(rng)).normalized();
      EXPECT_NEAR(loom_support(out[c], d), bullet_support(shapes[c], place[c], d), 1e-5) << c;
    }
}

TEST(BulletShapes, StaticPlaneAndTriangleMesh) {
  std::mt19937 rng(9);
  const btTransform tf = random_pose(rng);
  btStaticPlaneShape plane(btVector3(1, 2, 3).normalized(), 0.4);
  std::vector<Collider> out;
  std::vector<std::string> unsupported;
  bullet::map_shape(&plane, eig_tf(tf), "ground", out, unsupported);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].shape.type, ShapeType::plane);
  // Signed distance = n·p - c in the body frame.
  std::uniform_real_distribution<double> u(-2, 2);
  for (int k = 0; k < 50; ++k) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const double expect = eig(plane.getPlaneNormal()).dot(eig(tf.invXform(bt(p)))) - 0.4;
    EXPECT_NEAR(bullet::shape_signed_distance(out[0].shape, nullptr, out[0].curr, p, nullptr), expect, 1e-5);
  }

  btTriangleMesh tm;
  tm.addTriangle(btVector3(0, 0, 0), btVector3(1, 0, 0), btVector3(0, 0, 1));
  tm.addTriangle(btVector3(1, 0, 0), btVector3(1, 0, 1), btVector3(0, 0, 1));
  btBvhTriangleMeshShape mesh(&tm, true);
  out.clear();
  bullet::map_shape(&mesh, eig_tf(tf), "floor", out, unsupported);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].shape.type, ShapeType::mesh);
  EXPECT_EQ(out[0].shape.triangles.size(), 2u);
  // A point 0.1 above the middle of the quad is 0.1 away.
  const Vec3 p = eig(tf * btVector3(0.5, 0.1, 0.5));
  EXPECT_NEAR(bullet::shape_signed_distance(out[0].shape, nullptr, out[0].curr, p, nullptr), 0.1, 1e-5);
  EXPECT_TRUE(unsupported.empty());
}

// Signed distances of the mapped primitives: a point just outside / inside the surface along the support.
TEST(BulletShapes, SignedDistanceAtSupportPoints) {
  btBoxShape box(btVector3(0.2, 0.3, 0.4));
  btCylinderShapeZ cyl(btVector3(0.2, 0.2, 0.3));
  btCapsuleShapeX cap(0.1, 0.4);
  for (btConvexShape* s : std::initializer_list<btConvexShape*>{&box, &cyl, &cap}) {
    std::mt19937 rng(13);
    const btTransform tf = random_pose(rng);
    std::vector<Collider> out;
    std::vector<std::string> unsupported;
    bullet::map_shape(s, eig_tf(tf), "b", out, unsupported);
    ASSERT_EQ(out.size(), 1u);
    // Face centres along the local axes are at exactly the support distance.
    for (int axis = 0; axis < 3; ++axis)
      for (double sign : {-1.0, 1.0}) {
        btVector3 dl(0, 0, 0);
        dl[axis] = btScalar(sign);
        const btVector3 sp = s->localGetSupportingVertex(dl);
        const Vec3 surface = eig(tf * (dl * sp.dot(dl)));
        const Vec3 dir = eig(tf.getBasis() * dl);
        EXPECT_NEAR(
            bullet::shape_signed_distance(out[0].shape, nullptr, out[0].curr, surface + 0.01 * dir, nullptr),
            0.01, 1e-4)
            << s->getName() << " axis " << axis;
        EXPECT_NEAR(
            bullet::shape_signed_distance(out[0].shape, nullptr, out[0].curr, surface - 0.01 * dir, nullptr),
            -0.01, 1e-4)
            << s->getName() << " axis " << axis;
      }
  }
}

// An unsupported shape near the cloth is reported once, by name, and does not stop the simulation.
TEST(BulletShapes, UnsupportedShapeReportedOnce) {
  TestWorld w;
  const btVector3 centres[2] = {btVector3(0, 0, 0), btVector3(0.1, 0, 0)};
  const btScalar radii[2] = {0.1, 0.1};
  w.add_body(new btMultiSphereShape(centres, radii, 2), 0.0, Vec3(0.0, -0.05, 0.0));
  w.add_body(new btSphereShape(0.1), 0.0, Vec3(0.3, -0.12, 0.0));
  bullet::BulletClothSettings s = setup_tier();
  s.cloth_substeps = 8;
  bullet::BulletCloth* c = w.add_cloth(sheet(9, 0.8, Vec3(-0.4, 0.0, -0.4)), s);
  int calls = 0;
  c->set_warning_callback([&](const std::string&) { ++calls; });
  for (int f = 0; f < 10; ++f) w.frame();
  ASSERT_EQ(c->warnings().size(), 1u);
  EXPECT_EQ(c->warnings()[0], "MultiSphere");
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(c->colliders().size(), 1u);  // the sphere is still a collider
}

// The cloth is a broad-phase citizen: aabbTest finds its object, and its AABB holds every vertex.
TEST(BulletShapes, ClothObjectInBroadphase) {
  TestWorld w;
  bullet::BulletClothSettings s = setup_tier();
  s.cloth_substeps = 8;
  bullet::BulletCloth* c = w.add_cloth(sheet(9, 0.8, Vec3(-0.4, 1.0, -0.4)), s);
  for (int f = 0; f < 20; ++f) w.frame();
  struct Find : btBroadphaseAabbCallback {
    const btCollisionObject* target;
    bool found = false;
    bool process(const btBroadphaseProxy* p) override {
      found |= p->m_clientObject == target;
      return true;
    }
  } find;
  find.target = c->collision_object();
  const auto& x = c->simulation().cloths()[0]->state().x;
  w.world.getBroadphase()->aabbTest(bt(x[40]) - btVector3(0.01, 0.01, 0.01),
                                    bt(x[40]) + btVector3(0.01, 0.01, 0.01), find);
  EXPECT_TRUE(find.found);
  EXPECT_EQ(c->collision_object()->getInternalType(), btCollisionObject::CO_USER_TYPE);
  btVector3 lo, hi;
  c->collision_object()->getCollisionShape()->getAabb(c->collision_object()->getWorldTransform(), lo, hi);
  for (const Vec3& p : x)
    for (int k = 0; k < 3; ++k) {
      EXPECT_LE(lo[k], p[k] + 1e-5);
      EXPECT_GE(hi[k], p[k] - 1e-5);
    }
  EXPECT_LT(x[40].y(), 0.9);  // it fell
}

}  // namespace
}  // namespace loom::test
