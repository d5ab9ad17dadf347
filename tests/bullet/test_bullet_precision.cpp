// Which Bullet a test executable runs on (float and double builds). loom_bullet_tests links the
// float libraries, loom_bullet_double_tests the *-float64 ones with BT_USE_DOUBLE_PRECISION; a header and
// library that disagree on btScalar would corrupt every Bullet object silently, so check both the headers
// and the arithmetic done inside the linked library.
#include <gtest/gtest.h>

#include <cmath>

#include "BulletTestWorld.h"

namespace loom::test {
namespace {

TEST(BulletPrecision, HeadersMatchTheBuild) {
  EXPECT_EQ(sizeof(btScalar), LOOM_BULLET_DOUBLE ? sizeof(double) : sizeof(float));
#ifdef BT_USE_DOUBLE_PRECISION
  EXPECT_TRUE(LOOM_BULLET_DOUBLE);
#else
  EXPECT_FALSE(LOOM_BULLET_DOUBLE);
#endif
}

// A free body at 1 + 2^-30 m/s stepped once by 1/64 s: the library's integration (btRigidBody and
// btDiscreteDynamicsWorld code, not inline) moves it by exactly (1 + 2^-30) / 64 m in double precision; in
// single precision 1 + 2^-30 rounds to 1 and the step to exactly 1/64 m.
TEST(BulletPrecision, LinkedLibraryComputesInThePrecisionOfTheBuild) {
  TestWorld w(Vec3::Zero());
  btRigidBody* body = w.add_body(new btSphereShape(0.1), 1.0, Vec3::Zero());
  const double v = 1.0 + std::ldexp(1.0, -30);
  body->setLinearVelocity(btVector3(btScalar(v), 0, 0));
  const int substeps = w.world.stepSimulation(btScalar(1.0 / 64), 1, btScalar(1.0 / 64));
  ASSERT_EQ(substeps, 1);
  const double x = body->getCenterOfMassPosition().x();
  if (LOOM_BULLET_DOUBLE) {
    EXPECT_EQ(x, v / 64.0);
  } else {
    EXPECT_EQ(x, 1.0 / 64.0);
  }
  EXPECT_EQ(body->getCenterOfMassPosition().y(), 0.0);
}

}  // namespace
}  // namespace loom::test
