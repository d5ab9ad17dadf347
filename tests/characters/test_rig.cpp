// Capsule rig (issue 6): capsule endpoints at joint positions, radii from the body-proportion table.
#include <gtest/gtest.h>

#include "CharacterTestUtil.h"
#include "loom/characters/CapsuleRig.h"
#include "loom/cloth/Error.h"

namespace {

using namespace loom::characters;

void expect_endpoints_on_joints(const std::string& clip) {
  const Motion m = Motion::load(loom::test::mocap(clip));
  const CapsuleRig rig = CapsuleRig::build(m);
  ASSERT_GE(rig.bones().size(), 15u) << clip;
  std::vector<Transform> pose, caps;
  double worst = 0.0;
  for (double t : {0.0, 0.37, 1.9, 4.25, 10.0}) {
    m.pose(t, pose);
    rig.capsule_poses(pose, caps);
    for (size_t k = 0; k < caps.size(); ++k) {
      const Bone& b = rig.bones()[k];
      const Vec3 lo = caps[k] * Vec3(0.0, -b.half_length, 0.0), hi = caps[k] * Vec3(0.0, b.half_length, 0.0);
      worst = std::max(worst, (lo - pose[b.joint].translation()).norm());
      worst = std::max(worst, (hi - pose[b.child].translation()).norm());
      EXPECT_GT(b.radius, 0.0);
      EXPECT_LT(b.radius, b.half_length + 0.15);
    }
  }
  EXPECT_LE(worst, 1e-12) << clip;
}

TEST(CapsuleRig, EndpointsAtJointPositions_01_01) { expect_endpoints_on_joints("01_01.bvh"); }
TEST(CapsuleRig, EndpointsAtJointPositions_Boxing) { expect_endpoints_on_joints("Boxing_Toes.bvh"); }

TEST(CapsuleRig, RadiiFromTheProportionTableAcrossNamingConventions) {
  const Motion cmu = Motion::load(loom::test::mocap("01_01.bvh"));
  const Motion box = Motion::load(loom::test::mocap("Boxing_Toes.bvh"));
  const CapsuleRig a = CapsuleRig::build(cmu), b = CapsuleRig::build(box);
  // The upper arm: CMU "LeftArm", Biovision "LeftShoulder" (the clavicle is "LeftCollar" there).
  const int ua = a.find("LeftArm"), ub = b.find("LeftArm");
  ASSERT_GE(ua, 0);
  ASSERT_GE(ub, 0);
  EXPECT_EQ(a.bones()[ua].name, "LeftArm");
  EXPECT_EQ(b.bones()[ub].name, "LeftShoulder");
  EXPECT_EQ(b.bones()[b.find("LeftShoulder")].name, "LeftCollar");
  EXPECT_EQ(b.bones()[b.find("LeftLeg")].name, "LeftKnee");
  EXPECT_NEAR(a.bones()[ua].radius, default_bone_radii().at("LeftArm") * cmu.rest_height() / 1.7, 1e-15);
  // Thigh thicker than shin thicker than forearm; no capsules for fingers.
  EXPECT_GT(a.bones()[a.find("LeftUpLeg")].radius, a.bones()[a.find("LeftLeg")].radius);
  EXPECT_GT(a.bones()[a.find("LeftLeg")].radius, a.bones()[a.find("LeftForeArm")].radius);
  EXPECT_LT(a.find("LFingers"), 0);
  // Pelvis sides exist in both conventions.
  EXPECT_GE(a.find("LHipJoint"), 0);
  EXPECT_GE(b.find("LHipJoint"), 0);
  // The capsules come out as colliders.
  std::vector<Transform> pose;
  cmu.pose(0.0, pose);
  const auto colliders = a.make_colliders(pose);
  ASSERT_EQ(colliders.size(), a.bones().size());
  EXPECT_EQ(colliders[ua].shape.type, loom::collision::ShapeType::capsule);
  EXPECT_EQ(colliders[ua].name, "character/LeftArm");
}

TEST(CapsuleRig, RadiusOverridesByFileOrCanonicalName) {
  const Motion box = Motion::load(loom::test::mocap("Boxing_Toes.bvh"));
  const CapsuleRig r = CapsuleRig::build(box, {{"LeftShoulder", 0.07}, {"RightArm", 0.065}, {"LeftToeBase", 0.0}});
  EXPECT_DOUBLE_EQ(r.bones()[r.find("LeftArm")].radius, 0.07);   // by the file's name
  EXPECT_DOUBLE_EQ(r.bones()[r.find("RightArm")].radius, 0.065); // by the canonical name
  EXPECT_LT(r.find("LeftToeBase"), 0);                           // radius 0: no capsule
  try {
    CapsuleRig::build(box, {{"Tail", 0.05}});
    FAIL();
  } catch (const loom::Error& e) {
    EXPECT_NE(std::string(e.what()).find("radii.Tail"), std::string::npos);
  }
}

}  // namespace
