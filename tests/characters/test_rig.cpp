// Capsule rig: capsule endpoints at joint positions, radii from the body-proportion table.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "CharacterTestUtil.h"
#include "loom/characters/CapsuleRig.h"
#include "loom/cloth/Error.h"
#include "loom/collision/Distance.h"

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
  const CapsuleRig r =
      CapsuleRig::build(box, {{"LeftShoulder", 0.07}, {"RightArm", 0.065}, {"LeftToeBase", 0.0}});
  EXPECT_DOUBLE_EQ(r.bones()[r.find("LeftArm")].radius, 0.07);    // by the file's name
  EXPECT_DOUBLE_EQ(r.bones()[r.find("RightArm")].radius, 0.065);  // by the canonical name
  EXPECT_LT(r.find("LeftToeBase"), 0);                            // radius 0: no capsule
  try {
    CapsuleRig::build(box, {{"Tail", 0.05}});
    FAIL();
  } catch (const loom::Error& e) {
    EXPECT_NE(std::string(e.what()).find("radii.Tail"), std::string::npos);
  }
}

}  // namespace

namespace {

// Closest approach (m) of the capsule surfaces of any arm bone and any torso/leg bone over the clip (120 Hz),
// skipping pairs where a bone sits at the fit's floor (half its table radius).
double closest_arm_body_gap(const Motion& m, const CapsuleRig& rig, bool skip_floored) {
  const std::set<std::string> arm = {"LeftArm",  "RightArm",  "LeftForeArm",    "RightForeArm",
                                     "LeftHand", "RightHand", "LeftFingerBase", "RightFingerBase"};
  const std::set<std::string> body = {"Hips",       "LowerBack", "Spine",     "Spine1",
                                      "Chest",      "LHipJoint", "RHipJoint", "LeftUpLeg",
                                      "RightUpLeg", "LeftLeg",   "RightLeg"};
  auto floored = [](const Bone& b) { return b.radius <= 0.5 * b.table_radius + 1e-12; };
  std::vector<Transform> pose;
  double gap = 1e9;
  for (double t = 0.0; t <= m.duration(); t += 1.0 / 120.0) {
    m.pose(t, pose);
    for (const Bone& a : rig.bones())
      for (const Bone& b : rig.bones()) {
        if (!arm.count(a.canonical) || !body.count(b.canonical)) continue;
        if (skip_floored && (floored(a) || floored(b))) continue;
        const auto c = loom::collision::segment_segment_closest(
            pose[a.joint].translation(), pose[a.child].translation(), pose[b.joint].translation(),
            pose[b.child].translation());
        gap = std::min(gap, std::sqrt(c.distance_squared) - a.radius - b.radius);
      }
  }
  return gap;
}

// Mocap arms pass through the table's capsules (forearm into pelvis, hand into thigh); the fit shrinks radii
// so that arm and body capsules stay 2 cm apart over the clip, and leaves overridden radii alone.
TEST(CapsuleRig, RadiiFittedToTheMotionKeepArmsOffTheBody) {
  for (const char* clip : {"01_01.bvh", "Boxing_Toes.bvh"}) {
    const Motion m = Motion::load(loom::test::mocap(clip));
    CapsuleRig rig = CapsuleRig::build(m, {{"LeftForeArm", 0.05}});
    const CapsuleRig table = rig;
    EXPECT_LT(closest_arm_body_gap(m, table, false), 0.0) << clip;  // the table's capsules overlap somewhere
    EXPECT_GT(rig.fit_to_motion(m, 0.02), 0) << clip;
    // 2 cm where the floor allowed it (0.2 mm: the fit samples the clip at other instants than this check)
    EXPECT_GT(closest_arm_body_gap(m, rig, true), 0.02 - 2e-4) << clip;
    for (size_t k = 0; k < rig.bones().size(); ++k) {
      EXPECT_LE(rig.bones()[k].radius, table.bones()[k].radius) << clip;
      EXPECT_GE(rig.bones()[k].radius, 0.5 * table.bones()[k].radius - 1e-12) << clip;
      if (rig.bones()[k].canonical == "LeftForeArm") {
        EXPECT_EQ(rig.bones()[k].radius, 0.05) << clip;  // override kept
      }
    }
  }
}

}  // namespace
