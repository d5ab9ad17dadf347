#include "loom/characters/CapsuleRig.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <set>

#include "loom/cloth/Error.h"
#include "loom/collision/Distance.h"

namespace loom::characters {

namespace {

std::string strip_prefix(std::string name) {
  const size_t colon = name.find_last_of(':');
  if (colon != std::string::npos) name = name.substr(colon + 1);
  return name;
}

// Biovision / CMU-Acclaim aliases -> canonical names (used when the skeleton has *Collar joints).
const std::map<std::string, std::string>& collar_aliases() {
  static const std::map<std::string, std::string> m = {{"Ab", "Spine"},
                                                       {"LeftCollar", "LeftShoulder"},
                                                       {"RightCollar", "RightShoulder"},
                                                       {"LeftShoulder", "LeftArm"},
                                                       {"RightShoulder", "RightArm"},
                                                       {"LeftElbow", "LeftForeArm"},
                                                       {"RightElbow", "RightForeArm"},
                                                       {"LeftWrist", "LeftHand"},
                                                       {"RightWrist", "RightHand"},
                                                       {"LeftHip", "LeftUpLeg"},
                                                       {"RightHip", "RightUpLeg"},
                                                       {"LeftKnee", "LeftLeg"},
                                                       {"RightKnee", "RightLeg"},
                                                       {"LeftAnkle", "LeftFoot"},
                                                       {"RightAnkle", "RightFoot"},
                                                       {"LeftToes", "LeftToeBase"},
                                                       {"RightToes", "RightToeBase"}};
  return m;
}

// Common other spellings -> canonical names.
const std::map<std::string, std::string>& generic_aliases() {
  static const std::map<std::string, std::string> m = {{"Pelvis", "Hips"},
                                                       {"Hip", "Hips"},
                                                       {"Abdomen", "Spine"},
                                                       {"Spine2", "Chest"},
                                                       {"UpperChest", "Chest"},
                                                       {"LeftUpperArm", "LeftArm"},
                                                       {"RightUpperArm", "RightArm"},
                                                       {"LeftLowerArm", "LeftForeArm"},
                                                       {"RightLowerArm", "RightForeArm"},
                                                       {"LeftUpperLeg", "LeftUpLeg"},
                                                       {"RightUpperLeg", "RightUpLeg"},
                                                       {"LeftLowerLeg", "LeftLeg"},
                                                       {"RightLowerLeg", "RightLeg"},
                                                       {"LeftThigh", "LeftUpLeg"},
                                                       {"RightThigh", "RightUpLeg"},
                                                       {"LeftShin", "LeftLeg"},
                                                       {"RightShin", "RightLeg"},
                                                       {"LeftToe", "LeftToeBase"},
                                                       {"RightToe", "RightToeBase"}};
  return m;
}

}  // namespace

std::vector<std::string> canonical_joint_names(const Motion& motion) {
  bool collar = false;
  for (const Joint& j : motion.joints())
    collar = collar || strip_prefix(j.name).find("Collar") != std::string::npos;
  std::vector<std::string> out;
  for (const Joint& j : motion.joints()) {
    std::string n = strip_prefix(j.name);
    if (collar) {
      auto it = collar_aliases().find(n);
      if (it != collar_aliases().end()) n = it->second;
    }
    auto it = generic_aliases().find(n);
    if (it != generic_aliases().end()) n = it->second;
    out.push_back(n);
  }
  return out;
}

const std::map<std::string, double>& default_bone_radii() {
  // m, for a 1.7 m adult: hand-chosen round values (not fitted to an anthropometric data set); override
  // them per bone with the scene's `character.radii`.
  static const std::map<std::string, double> m = {
      {"Hips", 0.11},        {"LowerBack", 0.11},    {"Spine", 0.115},         {"Spine1", 0.12},
      {"Chest", 0.12},       {"Neck", 0.07},         {"Neck1", 0.055},         {"Head", 0.095},
      {"LHipJoint", 0.08},   {"RHipJoint", 0.08},    {"LeftUpLeg", 0.075},     {"RightUpLeg", 0.075},
      {"LeftLeg", 0.055},    {"RightLeg", 0.055},    {"LeftFoot", 0.045},      {"RightFoot", 0.045},
      {"LeftToeBase", 0.03}, {"RightToeBase", 0.03}, {"LeftShoulder", 0.055},  {"RightShoulder", 0.055},
      {"LeftArm", 0.048},    {"RightArm", 0.048},    {"LeftForeArm", 0.04},    {"RightForeArm", 0.04},
      {"LeftHand", 0.035},   {"RightHand", 0.035},   {"LeftFingerBase", 0.03}, {"RightFingerBase", 0.03},
      {"LFingers", 0.0},     {"RFingers", 0.0},      {"LThumb", 0.0},          {"RThumb", 0.0},
      {"default", 0.04}};
  return m;
}

CapsuleRig CapsuleRig::build(const Motion& motion, const std::map<std::string, double>& radii) {
  const std::vector<std::string> canon = canonical_joint_names(motion);
  const auto& joints = motion.joints();
  const double size = motion.rest_height() > 0.0 ? motion.rest_height() / 1.7 : 1.0;  // figure / table height
  std::set<std::string> used;
  for (const auto& [name, r] : radii)
    if (!(r >= 0.0)) throw Error(motion.source(), "radii." + name, "must be >= 0");
  // A bone belongs to the skeleton when its start joint is animated or below an animated joint.
  std::vector<bool> skeletal(joints.size(), false);
  for (size_t k = 0; k < joints.size(); ++k)
    skeletal[k] = joints[k].animated || (joints[k].parent >= 0 && skeletal[joints[k].parent]);
  CapsuleRig rig;
  const double min_length = 1e-6 * std::max(motion.rest_height(), 1e-3);
  for (size_t c = 0; c < joints.size(); ++c) {
    const int j = joints[c].parent;
    if (j < 0 || !skeletal[j]) continue;
    const Vec3 offset = joints[c].rest.translation();
    if (offset.norm() < min_length) continue;
    bool duplicate = false;
    for (const Bone& b : rig.bones_)
      duplicate =
          duplicate || (b.joint == j && (joints[b.child].rest.translation() - offset).norm() < min_length);
    if (duplicate) continue;
    Bone b;
    b.name = joints[j].name;
    b.canonical = canon[j];
    // The pelvis side of a hip (CMU LHipJoint; Biovision Hips -> LeftHip) has its own canonical bone.
    if (canon[c] == "LeftUpLeg" && canon[j] != "LHipJoint") b.canonical = "LHipJoint";
    if (canon[c] == "RightUpLeg" && canon[j] != "RHipJoint") b.canonical = "RHipJoint";
    b.joint = j;
    b.child = static_cast<int>(c);
    b.half_length = 0.5 * offset.norm();
    b.turn = Quat::FromTwoVectors(Vec3::UnitY(), offset);
    auto pick = [&](const std::string& key) -> const double* {
      auto it = radii.find(key);
      if (it == radii.end()) return nullptr;
      used.insert(key);
      return &it->second;
    };
    if (const double* r = pick(b.name)) {
      b.radius = *r;
      b.overridden = true;
      if (b.radius == 0.0) rig.removed_.emplace(b.canonical, b.name);
    } else if (const double* r2 = pick(b.canonical)) {
      b.radius = *r2;
      b.overridden = true;
      if (b.radius == 0.0) rig.removed_.emplace(b.canonical, b.canonical);
    } else {
      auto it = default_bone_radii().find(b.canonical);
      b.radius = size * (it != default_bone_radii().end() ? it->second : default_bone_radii().at("default"));
    }
    b.table_radius = b.radius;
    if (b.radius > 0.0) rig.bones_.push_back(b);
  }
  for (const auto& [name, r] : radii) {
    (void)r;
    if (!used.count(name)) {
      bool known = false;
      for (size_t k = 0; k < joints.size(); ++k) known = known || joints[k].name == name || canon[k] == name;
      if (!known && name != "LHipJoint" && name != "RHipJoint")
        throw Error(motion.source(), "radii." + name, "no bone of this skeleton has that name");
    }
  }
  return rig;
}

std::string CapsuleRig::removed_by(const std::string& canonical) const {
  const auto it = removed_.find(canonical);
  return it == removed_.end() ? std::string() : it->second;
}

void CapsuleRig::capsule_poses(const std::vector<Transform>& global, std::vector<Transform>& poses) const {
  poses.resize(bones_.size());
  for (size_t k = 0; k < bones_.size(); ++k) {
    const Bone& b = bones_[k];
    const Transform& g = global[b.joint];
    const Vec3 a = g.translation(), e = global[b.child].translation();
    // Rotation: the start joint's frame turned by the bone's fixed rest rotation (Bone::turn).
    Transform p = Transform::Identity();
    p.linear() = g.linear() * b.turn.toRotationMatrix();
    p.translation() = 0.5 * (a + e);
    poses[k] = p;
  }
}

std::vector<collision::Collider> CapsuleRig::make_colliders(const std::vector<Transform>& global) const {
  std::vector<Transform> poses;
  capsule_poses(global, poses);
  std::vector<collision::Collider> out;
  for (size_t k = 0; k < bones_.size(); ++k) {
    collision::Collider c;
    c.name = "character/" + bones_[k].name;
    c.shape.type = collision::ShapeType::capsule;
    c.shape.radius = bones_[k].radius;
    c.shape.half_height = bones_[k].half_length;
    c.prev = c.curr = poses[k];
    out.push_back(std::move(c));
  }
  return out;
}

collision::ColliderSetPtr CapsuleRig::clip_colliders(const Motion& motion) const {
  // The capsule poses at the last two sampled times, shared by the colliders (the contact stage samples
  // every collider at a step's start and end, one collider after the other).
  struct Clip {
    Clip(const CapsuleRig& r, const Motion& m) : rig(r), motion(m) {}
    CapsuleRig rig;
    Motion motion;
    double t[2] = {std::nan(""), std::nan("")};
    std::vector<Transform> poses[2], joints;
    int next = 0;
    const Transform& at(double time, size_t k) {
      for (int s = 0; s < 2; ++s)
        if (t[s] == time) return poses[s][k];
      const int s = next;
      next = 1 - next;
      motion.pose(time, joints);
      rig.capsule_poses(joints, poses[s]);
      t[s] = time;
      return poses[s][k];
    }
  };
  auto clip = std::make_shared<Clip>(*this, motion);
  std::vector<Transform> start;
  motion.pose(0.0, start);
  auto set = std::make_shared<collision::ColliderSet>(make_colliders(start));
  for (size_t k = 0; k < set->size(); ++k) (*set)[k].motion = [clip, k](double t) { return clip->at(t, k); };
  return set;
}

namespace {

const std::set<std::string> kArm = {"LeftArm",  "RightArm",  "LeftForeArm",    "RightForeArm",
                                    "LeftHand", "RightHand", "LeftFingerBase", "RightFingerBase"};

}  // namespace

int CapsuleRig::keep_clear_of(const Motion& motion, const std::vector<std::pair<int, Vec3>>& points,
                              double gap, double rate) {
  if (!(gap >= 0.0) || !(rate > 0.0) || points.empty()) return 0;
  std::vector<int> arms;
  for (size_t k = 0; k < bones_.size(); ++k)
    if (kArm.count(bones_[k].canonical) && !bones_[k].overridden) arms.push_back(static_cast<int>(k));
  std::vector<double> closest(bones_.size(), std::numeric_limits<double>::infinity());  // m, axis to a point
  std::vector<Transform> pose;
  for (const double t : motion.played_samples(rate)) {
    motion.pose(t, pose);
    for (int b : arms) {
      const Vec3 a = pose[bones_[b].joint].translation(), d = pose[bones_[b].child].translation() - a;
      const double l2 = d.squaredNorm();
      for (const auto& [joint, local] : points) {
        const Vec3 p = pose[joint] * local;
        const double s = l2 > 0.0 ? std::clamp((p - a).dot(d) / l2, 0.0, 1.0) : 0.0;
        closest[b] = std::min(closest[b], (p - a - s * d).norm());
      }
    }
  }
  int changed = 0;
  for (int b : arms) {
    const double want = std::max(0.5 * bones_[b].table_radius, closest[b] - gap);
    if (want < bones_[b].radius) bones_[b].radius = want, ++changed;
  }
  return changed;
}

int CapsuleRig::fit_to_motion(const Motion& motion, double gap, double rate) {
  const std::set<std::string>& arm = kArm;
  static const std::set<std::string> body = {"Hips",       "LowerBack", "Spine",     "Spine1",
                                             "Chest",      "LHipJoint", "RHipJoint", "LeftUpLeg",
                                             "RightUpLeg", "LeftLeg",   "RightLeg"};
  if (!(gap >= 0.0) || !(rate > 0.0)) return 0;
  std::vector<std::pair<int, int>> pairs;
  for (size_t a = 0; a < bones_.size(); ++a)
    for (size_t b = 0; b < bones_.size(); ++b)
      if (arm.count(bones_[a].canonical) && body.count(bones_[b].canonical))
        pairs.emplace_back(int(a), int(b));
  if (pairs.empty()) return 0;
  // Closest approach (m) of each pair's axes over the motion as it is played (clamped or one loop).
  std::vector<double> closest(pairs.size(), std::numeric_limits<double>::infinity());
  std::vector<Transform> pose;
  for (const double t : motion.played_samples(rate)) {
    motion.pose(t, pose);
    for (size_t p = 0; p < pairs.size(); ++p) {
      const Bone &a = bones_[pairs[p].first], &b = bones_[pairs[p].second];
      const double d2 =
          collision::segment_segment_closest(pose[a.joint].translation(), pose[a.child].translation(),
                                             pose[b.joint].translation(), pose[b.child].translation())
              .distance_squared;
      closest[p] = std::min(closest[p], std::sqrt(d2));
    }
  }
  std::vector<double> floor(bones_.size());
  for (size_t k = 0; k < bones_.size(); ++k)
    floor[k] = std::min(bones_[k].radius, 0.5 * bones_[k].table_radius);
  std::set<int> changed;
  // Tightest pairs first, so a bone shrunk for one pair is not shrunk again more than it needs.
  std::vector<size_t> order(pairs.size());
  for (size_t p = 0; p < order.size(); ++p) order[p] = p;
  std::sort(order.begin(), order.end(), [&](size_t x, size_t y) {
    const Bone &ax = bones_[pairs[x].first], &bx = bones_[pairs[x].second], &ay = bones_[pairs[y].first],
               &by = bones_[pairs[y].second];
    return closest[x] - ax.radius - bx.radius < closest[y] - ay.radius - by.radius;
  });
  for (size_t p : order) {
    Bone &a = bones_[pairs[p].first], &b = bones_[pairs[p].second];
    double excess = a.radius + b.radius + gap - closest[p];  // m, how much the radii must lose
    if (excess <= 0.0) continue;
    if (!a.overridden) {
      const double cut = std::min(excess, a.radius - floor[pairs[p].first]);
      if (cut > 0.0) a.radius -= cut, excess -= cut, changed.insert(pairs[p].first);
    }
    if (excess > 0.0 && !b.overridden) {
      const double cut = std::min(excess, b.radius - floor[pairs[p].second]);
      if (cut > 0.0) b.radius -= cut, changed.insert(pairs[p].second);
    }
  }
  return static_cast<int>(changed.size());
}

int CapsuleRig::find(const std::string& canonical) const {
  for (size_t k = 0; k < bones_.size(); ++k)
    if (bones_[k].canonical == canonical) return static_cast<int>(k);
  return -1;
}

}  // namespace loom::characters
