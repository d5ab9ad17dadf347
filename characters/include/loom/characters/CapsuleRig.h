#pragma once
// CapsuleRig: one capsule per bone of a Motion's skeleton. A bone runs from a joint to one of its
// children; its capsule's segment joins the two joints' positions (Collider.h: local y axis, from
// -half_height to +half_height) and its radius comes from a body-proportion table keyed by common bone
// names (canonical names below; other naming conventions are mapped onto them), scaled with the figure's
// height, and overridable per bone. Bones of zero length, duplicates (several children at one offset) and
// bones whose radius is 0 (fingers) get no capsule.
#include <map>
#include <string>
#include <vector>

#include "loom/characters/Motion.h"
#include "loom/collision/Collider.h"

namespace loom::characters {

// Canonical names (CMU / Mixamo style): Hips, LowerBack, Spine, Spine1, Chest, Neck, Neck1, Head,
// LHipJoint/RHipJoint (pelvis to hip), LeftUpLeg, LeftLeg, LeftFoot, LeftToeBase, LeftShoulder (clavicle),
// LeftArm, LeftForeArm, LeftHand, and the Right* twins. Biovision names (LeftCollar, LeftShoulder = upper
// arm, LeftElbow, LeftWrist, LeftHip, LeftKnee, LeftAnkle, LeftToes, Ab) are recognised when the skeleton
// has a *Collar joint; "mixamorig:" and similar prefixes are dropped.
std::vector<std::string> canonical_joint_names(const Motion& motion);

// Default radii (m) for a 1.7 m figure, keyed by canonical bone name; unknown names get "default".
const std::map<std::string, double>& default_bone_radii();

struct Bone {
  std::string name;           // the start joint's name in the file
  std::string canonical;      // canonical name used for the radius and for garment fitting
  int joint = 0;              // start joint (the capsule moves with its frame)
  int child = 0;              // end joint
  double radius = 0.0;        // m
  double half_length = 0.0;   // m, half the rest distance between the joints
  double table_radius = 0.0;  // m, the radius before fitting (table or override)
  bool overridden = false;    // radius given by the scene (`radii`): the fits leave it alone
  // Rotation, in the start joint's frame, taking the capsule's local y onto the bone (the child's rest
  // offset). Fixed per bone, so the capsule is rigidly attached to the joint's frame: no twist flips when
  // the bone points along -y (Biovision legs), which would give the capsule's surface a spurious spin.
  Quat turn = Quat::Identity();
};

class CapsuleRig {
 public:
  // `radii`: overrides by file name or canonical name (m). Unknown override names throw loom::Error
  // (file = the motion's source, where = "radii.<name>").
  static CapsuleRig build(const Motion& motion, const std::map<std::string, double>& radii = {});

  const std::vector<Bone>& bones() const { return bones_; }
  // Capsule pose of each bone for the given global joint transforms: centre at the joints' midpoint, local
  // y along the bone (start joint at -y), twist from the start joint's frame.
  void capsule_poses(const std::vector<Transform>& global, std::vector<Transform>& poses) const;
  // One Collider per bone (shape capsule), named "character/<bone>", with the poses at `global`.
  std::vector<collision::Collider> make_colliders(const std::vector<Transform>& global) const;
  // The same colliders moving with `motion`'s clip, for GarmentInstance::set_colliders: each one's `motion`
  // is its capsule's pose at the clip's time t (s, Motion::pose), so the contact stage samples the clip at
  // both ends of every fixed step. The set holds copies of the rig and the motion.
  collision::ColliderSetPtr clip_colliders(const Motion& motion) const;
  // Fits the table radii to the motion: mocap limbs pass through the table's round capsules (a forearm
  // swinging past the hip overlaps the pelvis capsule), and cloth
  // caught between two overlapping capsules cannot be outside both. For every pair of an arm bone
  // (upper arm, forearm, hand, finger base) and a torso or leg bone (pelvis, spine, chest, hips, thighs,
  // shins), the closest approach of the two axes over the played motion (Motion::played_samples(rate)) is
  // measured; when the capsules come closer than `gap` (m), the arm's radius shrinks (down to half its table
  // value), then the body's. Overridden radii are kept. Returns the number of radii changed.
  int fit_to_motion(const Motion& motion, double gap, double rate = 120.0);
  // Shrinks arm capsules (as fit_to_motion, down to half their table radius) that come closer than `gap` (m)
  // to any of `points` (a joint and a position in its frame: garment vertices attached to bones) over the
  // played motion: an attached vertex cannot be pushed out of a capsule. Returns the number of radii changed.
  int keep_clear_of(const Motion& motion, const std::vector<std::pair<int, Vec3>>& points, double gap,
                    double rate = 120.0);
  // Index of the first bone whose canonical name is `canonical` (-1 if none).
  int find(const std::string& canonical) const;
  // The `radii` key whose radius 0 removed the bone of canonical name `canonical` (empty if none did).
  std::string removed_by(const std::string& canonical) const;

 private:
  std::vector<Bone> bones_;
  std::map<std::string, std::string> removed_;  // canonical name -> the `radii` key that gave it 0
};

}  // namespace loom::characters
