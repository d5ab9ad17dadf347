#include "loom/characters/BodyFit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numeric>
#include <optional>
#include <set>
#include <unordered_map>

#include "loom/cloth/Error.h"
#include "loom/collision/Distance.h"

namespace loom::characters {

namespace {

// Heights above the floor and segment lengths as fractions of the body height H (Drillis and Contini 1966,
// in Winter 2009, Fig. 4.1).
constexpr double kHipHeight = 0.530;       // greater trochanter (hip joint) height
constexpr double kKneeHeight = 0.285;      // knee
constexpr double kAnkleHeight = 0.039;     // ankle
constexpr double kShoulderHeight = 0.818;  // acromion
constexpr double kShoulderWidth = 0.259;   // biacromial width
constexpr double kUpperArm = 0.186;
constexpr double kForearm = 0.146;
constexpr double kHand = 0.108;

// Canonical names of the limb bones (arms and legs, CapsuleRig.h): their sections are round about the bone.
const std::set<std::string> kLimbBones = {"LeftUpLeg",  "LeftLeg",      "LeftFoot",  "LeftToeBase",
                                          "LeftArm",    "LeftForeArm",  "LeftHand",  "LeftFingerBase",
                                          "RightUpLeg", "RightLeg",     "RightFoot", "RightToeBase",
                                          "RightArm",   "RightForeArm", "RightHand", "RightFingerBase"};

int find_canonical(const std::vector<std::string>& canon, const std::string& name) {
  for (size_t j = 0; j < canon.size(); ++j)
    if (canon[j] == name) return static_cast<int>(j);
  return -1;
}

// Length-weighted centroid of a polyline's point at arc length `s` from its start.
Vec3 along(const std::vector<Vec3>& path, double s) {
  for (size_t k = 1; k < path.size(); ++k) {
    const double l = (path[k] - path[k - 1]).norm();
    if (s <= l && l > 0.0) return path[k - 1] + (s / l) * (path[k] - path[k - 1]);
    s -= l;
  }
  return path.back();
}

double arc_length(const std::vector<Vec3>& path) {
  double l = 0.0;
  for (size_t k = 1; k < path.size(); ++k) l += (path[k] - path[k - 1]).norm();
  return l;
}

bool is_descendant(const Motion& motion, int j, int ancestor) {
  for (int k = j; k >= 0; k = motion.joints()[k].parent)
    if (k == ancestor) return true;
  return false;
}

// The horizontal sections of the scaled mesh and the landmarks found in them.
class BodySections {
 public:
  BodySections(const cloth::Vec3s& x, const std::vector<cloth::Tri>& tris, const std::string& source)
      : x_(x), tris_(tris), source_(source) {
    Vec3 lo = x[0], hi = x[0];
    for (const Vec3& p : x) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    floor_ = lo.y();
    height_ = hi.y() - lo.y();
    mid_ = 0.5 * (lo.x() + hi.x());
  }
  double floor() const { return floor_; }
  double height() const { return height_; }
  double mid() const { return mid_; }
  double at(double fraction) const { return floor_ + fraction * height_; }

  std::vector<SectionLoop> loops(double y) const {
    return mesh_section(x_, tris_, Vec3(0.0, y, 0.0), Vec3::UnitY());
  }
  // Distance from the midline to the loop's nearest point, when the whole loop is on side `sg` (+1: +x).
  std::optional<double> inner(const SectionLoop& l, int sg) const {
    const double d = sg > 0 ? l.lo.x() - mid_ : mid_ - l.hi.x();
    if (d > 0.0) return d;
    return std::nullopt;
  }
  // The leg's section at height y: the largest loop on side sg within 0.1 H of the midline.
  std::optional<SectionLoop> leg(double y, int sg) const {
    std::optional<SectionLoop> best;
    for (const SectionLoop& l : loops(y)) {
      const auto d = inner(l, sg);
      if (d && *d < 0.1 * height_ && (!best || l.perimeter > best->perimeter)) best = l;
    }
    return best;
  }
  // The loop on side sg at height y nearest to `near` (within `reach`), or the largest when reach is 0.
  std::optional<SectionLoop> side(double y, int sg, const Vec3& near, double reach) const {
    std::optional<SectionLoop> best;
    double best_key = std::numeric_limits<double>::infinity();
    for (const SectionLoop& l : loops(y)) {
      if (!inner(l, sg)) continue;
      const double key = reach > 0.0 ? (l.centroid - near).norm() : -l.perimeter;
      if (reach > 0.0 && key > reach) continue;
      if (key < best_key) best_key = key, best = l;
    }
    return best;
  }
  const cloth::Vec3s& x() const { return x_; }
  const std::string& source() const { return source_; }

 private:
  const cloth::Vec3s& x_;
  const std::vector<cloth::Tri>& tris_;
  std::string source_;
  double floor_ = 0.0, height_ = 0.0, mid_ = 0.0;
};

std::string side_name(int sg) { return sg > 0 ? "left" : "right"; }

struct Leg {
  Vec3 hip, knee, ankle, tip;  // tip: the foot's farthest forward vertex
};

Leg find_leg(const BodySections& b, int sg) {
  const double h = b.height();
  const std::string field = side_name(sg) + "_leg";
  auto need = [&](const std::optional<SectionLoop>& l, double y, const std::string& what) {
    if (!l)
      throw Error(b.source(), field,
                  "no separate section of the leg at " + what + " height (y = " + std::to_string(y) +
                      " m): the mesh is not standing with its legs apart");
    return l->centroid;
  };
  Leg leg;
  const double y_knee = b.at(kKneeHeight), y_ankle = b.at(kAnkleHeight), y_hip = b.at(kHipHeight);
  leg.knee = need(b.leg(y_knee, sg), y_knee, "knee");
  leg.ankle = need(b.leg(y_ankle, sg), y_ankle, "ankle");
  // Crotch: the highest height below the hip at which the leg's section is apart from the other leg.
  double y_cr = y_hip;
  while (y_cr > y_knee && !b.leg(y_cr, sg)) y_cr -= 0.0025 * h;
  if (y_cr <= y_knee) need(std::nullopt, y_hip, "thigh");
  // The thigh's axis through its sections at 40 % and 70 % of the way from the hip to the knee (below the
  // crotch, above the knee).
  const double y1 = std::min(y_hip - 0.4 * (y_hip - y_knee), y_cr - 0.01 * h);
  const double y2 = y_hip - 0.7 * (y_hip - y_knee);
  const Vec3 c1 = need(b.leg(y1, sg), y1, "thigh"), c2 = need(b.leg(y2, sg), y2, "thigh");
  leg.hip = c1 + (c1 - c2) * ((y_hip - c1.y()) / (c1.y() - c2.y()));
  // Foot tip: the farthest forward vertex below the ankle within 0.1 H of it across.
  leg.tip = leg.ankle;
  double heel = leg.ankle.z();
  for (const Vec3& p : b.x())
    if (p.y() < leg.ankle.y() && std::abs(p.x() - leg.ankle.x()) < 0.1 * h) {
      if (p.z() > leg.tip.z()) leg.tip = p;
      heel = std::min(heel, p.z());
    }
  // The foot reaches farther forward (toes) than back (heel): a mesh facing -z has it the other way round.
  if (leg.tip.z() - leg.ankle.z() < leg.ankle.z() - heel)
    throw Error(b.source(), field,
                "the foot points along -z: the mesh must face +z (turn it with the loader)");
  // The section at ankle height also cuts the heel and the instep: the ankle is on the shin's axis (through
  // its sections at 0.10 H and 0.20 H, above the malleoli) at that height.
  const double y3 = b.at(0.10), y4 = b.at(0.20);
  const Vec3 c3 = need(b.leg(y3, sg), y3, "shin"), c4 = need(b.leg(y4, sg), y4, "shin");
  leg.ankle = c3 + (c3 - c4) * ((y_ankle - c3.y()) / (c3.y() - c4.y()));
  return leg;
}

struct Arm {
  Vec3 shoulder, elbow, wrist, tip;
};

Arm find_arm(const BodySections& b, int sg) {
  const double h = b.height();
  const std::string field = side_name(sg) + "_arm";
  auto fail = [&](const std::string& what) {
    throw Error(b.source(), field,
                what + ": the mesh is not in an A-pose (arms apart, pointing down-and-out)");
  };
  // Armpit: scanning down from shoulder height, the first section with the arm apart from the torso.
  double y = b.at(kShoulderHeight);
  std::optional<SectionLoop> first;
  while (y > b.at(kHipHeight) && !(first = b.side(y, sg, Vec3::Zero(), 0.0))) y -= 0.0025 * h;
  if (!first) fail("no section of the arm apart from the torso above hip height");
  first = b.side(y - 0.005 * h, sg, first->centroid, 0.05 * h);
  if (!first) fail("the arm's section vanishes below the armpit");
  // Centre line: section centroids tracked downward until the fingertips.
  std::vector<Vec3> line = {first->centroid};
  for (double yy = first->centroid.y() - 0.005 * h; yy > b.floor(); yy -= 0.005 * h) {
    auto next = b.side(yy, sg, line.back(), 0.05 * h);
    if (!next) break;
    line.push_back(next->centroid);
  }
  const Vec3 c0 = line.front();
  Arm arm;
  arm.tip = c0;
  for (const Vec3& p : b.x())
    if (sg * (p.x() - b.mid()) > sg * (c0.x() - b.mid()) && p.y() > b.at(kKneeHeight) &&
        (p - c0).norm() > (arm.tip - c0).norm())
      arm.tip = p;
  // Upper arm axis (pointing up, toward the shoulder): first through the armpit's section and the one
  // 0.08 H down the centre line, then (once the elbow is placed) through the centre line at 40 % and 70 % of
  // the way from the shoulder to the elbow.
  Vec3 cm = line.back();
  for (const Vec3& p : line)
    if ((p - c0).norm() >= 0.08 * h) {
      cm = p;
      break;
    }
  if ((cm - c0).norm() < 0.04 * h) fail("the arm's section is too short");
  const double radius = first->perimeter / (2.0 * M_PI);
  const double lateral = 0.5 * kShoulderWidth * h - radius;
  Vec3 a = c0, axis = (c0 - cm).normalized();
  for (int pass = 0; pass < 2; ++pass) {
    if (sg * axis.x() > -0.1) fail("the upper arm does not point away from the torso");
    const double t = (lateral - sg * (a.x() - b.mid())) / (sg * axis.x());
    arm.shoulder = a + t * axis;
    if (sg * (arm.shoulder.x() - b.mid()) > sg * (c0.x() - b.mid()))
      fail("the armpit lies inside the shoulder width");
    std::vector<Vec3> path = {arm.shoulder};
    path.insert(path.end(), line.begin(), line.end());
    path.push_back(arm.tip);
    const double length = arc_length(path), total = kUpperArm + kForearm + kHand;
    const double upper = length * kUpperArm / total;
    arm.elbow = along(path, upper);
    arm.wrist = along(path, length * (kUpperArm + kForearm) / total);
    const Vec3 p1 = along(path, 0.4 * upper), p2 = along(path, 0.7 * upper);
    if ((p1 - p2).norm() < 0.02 * h) break;
    a = p1;
    axis = (p1 - p2).normalized();
  }
  return arm;
}

}  // namespace

std::vector<SectionLoop> mesh_section(const cloth::Vec3s& x, const std::vector<cloth::Tri>& tris,
                                      const Vec3& point, const Vec3& normal) {
  const Vec3 n = normal.normalized();
  std::vector<double> d(x.size());
  for (size_t i = 0; i < x.size(); ++i) d[i] = n.dot(x[i] - point);
  // Vertices at the same position are one (meshes split vertices along UV seams).
  struct PositionHash {
    size_t operator()(const Vec3& p) const {
      size_t h = std::hash<double>()(p.x());
      h = h * 1000003u ^ std::hash<double>()(p.y());
      return h * 1000003u ^ std::hash<double>()(p.z());
    }
  };
  std::unordered_map<Vec3, int, PositionHash> first_at;
  std::vector<int> weld(x.size());
  for (size_t i = 0; i < x.size(); ++i) weld[i] = first_at.emplace(x[i], static_cast<int>(i)).first->second;
  std::unordered_map<std::uint64_t, int> edge_id;
  std::vector<int> parent;
  std::vector<Vec3> cut;
  auto id = [&](int a, int b) {
    if (a > b) std::swap(a, b);
    const std::uint64_t key = (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
    auto [it, inserted] = edge_id.emplace(key, static_cast<int>(parent.size()));
    if (inserted) {
      parent.push_back(it->second);
      const double u = d[a] / (d[a] - d[b]);
      cut.push_back(x[a] + u * (x[b] - x[a]));
    }
    return it->second;
  };
  auto root = [&](int e) {
    while (parent[e] != e) e = parent[e] = parent[parent[e]];
    return e;
  };
  std::vector<std::pair<int, int>> segments;
  for (const cloth::Tri& t : tris) {
    int e[3], k = 0;
    for (int s = 0; s < 3; ++s) {
      const int a = weld[t[s]], b = weld[t[(s + 1) % 3]];
      if ((d[a] >= 0.0) != (d[b] >= 0.0)) e[k++] = id(a, b);
    }
    if (k != 2) continue;
    segments.emplace_back(e[0], e[1]);
    const int r0 = root(e[0]), r1 = root(e[1]);
    if (r0 != r1) parent[r0] = r1;
  }
  std::unordered_map<int, int> loop_of;
  std::vector<SectionLoop> loops;
  std::vector<Vec3> weighted;
  for (const auto& [a, b] : segments) {
    const int r = root(a);
    auto [it, inserted] = loop_of.emplace(r, static_cast<int>(loops.size()));
    if (inserted) {
      loops.emplace_back();
      loops.back().lo = loops.back().hi = cut[a];
      weighted.push_back(Vec3::Zero());
    }
    SectionLoop& l = loops[it->second];
    const double len = (cut[b] - cut[a]).norm();
    l.perimeter += len;
    weighted[it->second] += len * 0.5 * (cut[a] + cut[b]);
    l.lo = l.lo.cwiseMin(cut[a]).cwiseMin(cut[b]);
    l.hi = l.hi.cwiseMax(cut[a]).cwiseMax(cut[b]);
  }
  for (size_t k = 0; k < loops.size(); ++k)
    loops[k].centroid = loops[k].perimeter > 0.0 ? Vec3(weighted[k] / loops[k].perimeter)
                                                 : Vec3(0.5 * (loops[k].lo + loops[k].hi));
  return loops;
}

BodyFit fit_body(const SkinnedMesh& mesh, const Motion& motion) {
  const std::string& src = mesh.source;
  if (mesh.positions.empty()) throw Error(src, "positions", "the mesh has no vertices");
  if (mesh.triangles.empty()) throw Error(src, "triangles", "the mesh has no triangles");
  for (size_t i = 0; i < mesh.positions.size(); ++i)
    if (!mesh.positions[i].allFinite())
      throw Error(src, "positions[" + std::to_string(i) + "]", "is not finite");
  const int nv = static_cast<int>(mesh.positions.size());
  for (size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (mesh.triangles[t][k] < 0 || mesh.triangles[t][k] >= nv)
        throw Error(src, "triangles[" + std::to_string(t) + "]", "vertex index out of range");

  // The skeleton's joints by canonical name.
  const std::vector<std::string> canon = canonical_joint_names(motion);
  const auto& joints = motion.joints();
  const int nj = motion.num_joints();
  auto joint = [&](const std::string& name) {
    const int j = find_canonical(canon, name);
    if (j < 0)
      throw Error(motion.source(), "joints",
                  "no joint '" + name +
                      "' (or an alias of it): the body fit needs hips, knees, ankles, "
                      "shoulders, elbows and wrists");
    return j;
  };
  struct Side {
    int sg, up_leg, leg, foot, toe, arm, fore_arm, hand, clavicle;
  };
  std::vector<Side> sides;
  for (int sg : {1, -1}) {
    const std::string p = sg > 0 ? "Left" : "Right";
    Side s{sg,
           joint(p + "UpLeg"),
           joint(p + "Leg"),
           joint(p + "Foot"),
           find_canonical(canon, p + "ToeBase"),
           joint(p + "Arm"),
           joint(p + "ForeArm"),
           joint(p + "Hand"),
           find_canonical(canon, p + "Shoulder")};
    sides.push_back(s);
  }
  const int root = motion.root();

  // Rest pose (m): global transforms.
  std::vector<Transform> rest(nj);
  for (int j = 0; j < nj; ++j)
    rest[j] = joints[j].parent >= 0 ? Transform(rest[joints[j].parent] * joints[j].rest) : joints[j].rest;
  auto rest_at = [&](int j) -> Vec3 { return rest[j].translation(); };

  // 1. Scale.
  double ylo = mesh.positions[0].y(), yhi = ylo;
  for (const Vec3& p : mesh.positions) ylo = std::min(ylo, p.y()), yhi = std::max(yhi, p.y());
  if (!(yhi - ylo > 0.0)) throw Error(src, "positions", "the mesh has no height");
  BodyFit fit;
  fit.scale = motion.rest_height() / (yhi - ylo);
  if (!(fit.scale > 0.0) || !std::isfinite(fit.scale))
    throw Error(motion.source(), "joints", "the skeleton's rest pose has no height");
  cloth::Vec3s x(mesh.positions.size());
  for (size_t i = 0; i < x.size(); ++i) x[i] = fit.scale * mesh.positions[i];

  // 2. Joints found in the mesh.
  const BodySections b(x, mesh.triangles, src);
  const double h = b.height();
  std::vector<std::optional<Vec3>> anchor(nj);
  Vec3 hand_tip[2];
  for (size_t k = 0; k < sides.size(); ++k) {
    const Side& s = sides[k];
    Leg leg = find_leg(b, s.sg);
    Arm arm = find_arm(b, s.sg);
    anchor[s.up_leg] = leg.hip;
    anchor[s.leg] = leg.knee;
    anchor[s.foot] = leg.ankle;
    if (s.toe >= 0) {
      // The toe joint where the skeleton has it between the ankle and the foot's end (horizontally).
      double f = 0.7;
      for (int c = 0; c < nj; ++c)
        if (joints[c].parent == s.toe) {
          const Vec3 a = rest_at(s.foot), t = rest_at(s.toe), e = rest_at(c);
          const double d1 = Eigen::Vector2d(t.x() - a.x(), t.z() - a.z()).norm();
          const double d2 = Eigen::Vector2d(e.x() - t.x(), e.z() - t.z()).norm();
          if (d1 + d2 > 0.0) f = d1 / (d1 + d2);
          break;
        }
      // Horizontally a fraction f from the ankle to the foot's tip, half the ankle's height above the floor.
      Vec3 toe = leg.ankle + f * (leg.tip - leg.ankle);
      toe.y() = b.floor() + 0.5 * (leg.ankle.y() - b.floor());
      anchor[s.toe] = toe;
    }
    anchor[s.arm] = arm.shoulder;
    anchor[s.fore_arm] = arm.elbow;
    anchor[s.hand] = arm.wrist;
    hand_tip[k] = arm.tip;
    for (int j : {s.up_leg, s.leg, s.foot, s.arm, s.fore_arm, s.hand}) fit.measured.push_back(j);
  }
  std::sort(fit.measured.begin(), fit.measured.end());

  // Chest: the joint the clavicles (or the upper arms) hang from.
  const int chest = joints[sides[0].clavicle >= 0 ? sides[0].clavicle : sides[0].arm].parent;
  if (chest < 0) throw Error(motion.source(), "joints", "the shoulders have no parent joint");
  auto in_arm = [&](int j) {
    for (const Side& s : sides)
      if (is_descendant(motion, j, s.clavicle >= 0 ? s.clavicle : s.arm)) return true;
    return false;
  };
  // The hand's direction: toward its farthest descendant at rest.
  int hand_far[2];
  for (size_t k = 0; k < sides.size(); ++k) {
    hand_far[k] = sides[k].hand;
    for (int j = 0; j < nj; ++j)
      if (is_descendant(motion, j, sides[k].hand) &&
          (rest_at(j) - rest_at(sides[k].hand)).norm() >
              (rest_at(hand_far[k]) - rest_at(sides[k].hand)).norm())
        hand_far[k] = j;
  }

  // Root: the skeleton's rest offset from the hips' midpoint to the root, kept.
  std::vector<Vec3> S(nj, Vec3::Zero()), T(nj, Vec3::Zero());
  std::vector<Quat> Q(nj, Quat::Identity());
  const Vec3 hips_found = 0.5 * (*anchor[sides[0].up_leg] + *anchor[sides[1].up_leg]);
  const Vec3 hips_rest = 0.5 * (rest_at(sides[0].up_leg) + rest_at(sides[1].up_leg));
  const Vec3 root_found = hips_found + (rest_at(root) - hips_rest);
  // Vertical stretch of the spine (root to chest) so that the shoulders meet the mesh's, and of the head
  // chain (chest to the highest joint) so that its top meets the mesh's top.
  const double shoulder_y = 0.5 * (anchor[sides[0].arm]->y() + anchor[sides[1].arm]->y());
  const double shoulder_rest_y = 0.5 * (rest_at(sides[0].arm).y() + rest_at(sides[1].arm).y());
  const double spine_rest = rest_at(chest).y() - rest_at(root).y();
  const double k_spine =
      spine_rest > 0.01 * h
          ? (shoulder_y - (shoulder_rest_y - rest_at(chest).y()) - root_found.y()) / spine_rest
          : 1.0;
  int top = chest;
  for (int j = 0; j < nj; ++j)
    if (is_descendant(motion, j, chest) && !in_arm(j) && rest_at(j).y() > rest_at(top).y()) top = j;
  const double chest_found_y = root_found.y() + k_spine * spine_rest;
  const double head_rest = rest_at(top).y() - rest_at(chest).y();
  const double k_head = head_rest > 0.01 * h ? (b.at(1.0) - chest_found_y) / head_rest : 1.0;
  double k_hand[2];
  for (int k = 0; k < 2; ++k) {
    const double l = (rest_at(hand_far[k]) - rest_at(sides[k].hand)).norm();
    k_hand[k] = l > 0.0 ? (hand_tip[k] - *anchor[sides[k].hand]).norm() / l : 1.0;
  }

  // 3. The bind pose: rotations turning each bone toward its found child; found (S) and bind (T) joints.
  std::vector<bool> skeletal(nj, false);
  for (int j = 0; j < nj; ++j) skeletal[j] = is_descendant(motion, j, root);
  for (int j = 0; j < nj; ++j) {
    const int p = joints[j].parent;
    if (!skeletal[j]) continue;
    const Quat qp = (j == root || p < 0) ? Quat::Identity() : Q[p];
    Q[j] = j == root ? Quat(rest[j].rotation()) : Quat(qp * Quat(joints[j].rest.rotation()));
    if (j == root) {
      S[j] = T[j] = root_found;
    } else {
      const Vec3 off = qp * joints[j].rest.translation();
      T[j] = T[p] + off;
      // Stretch of the bone from the parent to j: spine (root to chest), head chain, hand, else none.
      double k = 1.0;
      if (is_descendant(motion, chest, j))
        k = k_spine;
      else if (is_descendant(motion, j, chest) && !in_arm(j))
        k = k_head;
      for (int s = 0; s < 2; ++s)
        if (j != sides[s].hand && is_descendant(motion, j, sides[s].hand)) k = k_hand[s];
      S[j] = anchor[j] ? *anchor[j] : Vec3(S[p] + k * off);
    }
    // Aim: the only child off the joint, when it was found in the mesh (or the hand's tip).
    std::optional<Vec3> target;
    Vec3 local = Vec3::Zero();
    int off_joint = 0, child = -1;
    for (int c = 0; c < nj; ++c)
      if (joints[c].parent == j && joints[c].rest.translation().norm() > 1e-9) ++off_joint, child = c;
    if (off_joint == 1 && anchor[child]) {
      target = *anchor[child];
      local = joints[child].rest.translation();
    }
    for (int s = 0; s < 2; ++s)
      if (j == sides[s].hand && hand_far[s] != j) {
        target = hand_tip[s];
        local = rest[j].inverse() * rest_at(hand_far[s]);
      }
    if (target && (*target - S[j]).norm() > 1e-9)
      Q[j] = Quat::FromTwoVectors(Q[j] * local, *target - S[j]) * Q[j];
  }

  // 4. Move the mesh from the found joints onto the bind pose: per bone, S_j -> T_j and a stretch along the
  //    bone by (bind length / found length), blended with automatic weights at the found joints.
  std::vector<std::string> names;
  std::vector<int> bones, bone_of(nj, -1), parents;
  for (int j = 0; j < nj; ++j)
    if (skeletal[j]) {
      bone_of[j] = static_cast<int>(bones.size());
      bones.push_back(j);
      names.push_back(joints[j].name);
      parents.push_back(joints[j].parent >= 0 ? bone_of[joints[j].parent] : -1);
    }
  std::vector<Affine> found_frames, bind_frames, maps;
  for (int j : bones) {
    Affine f = Affine::Identity();
    f.translation() = S[j];
    found_frames.push_back(f);
    Affine g = Affine::Identity();
    g.linear() = Q[j].toRotationMatrix();
    g.translation() = T[j];
    bind_frames.push_back(g);
    // Stretch along the bone to its only child off the joint (or the hand's tip).
    std::vector<int> kids;
    for (int c = 0; c < nj; ++c)
      if (joints[c].parent == j && joints[c].rest.translation().norm() > 1e-9) kids.push_back(c);
    Vec3 es = Vec3::Zero(), et = Vec3::Zero();
    if (kids.size() == 1) es = S[kids[0]] - S[j], et = T[kids[0]] - T[j];
    for (int s = 0; s < 2; ++s)
      if (j == sides[s].hand && hand_far[s] != j) es = hand_tip[s] - S[j], et = T[hand_far[s]] - T[j];
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    if (es.norm() > 1e-6 * h) {
      const Vec3 u = es.normalized();
      m += (et.norm() / es.norm() - 1.0) * u * u.transpose();
    }
    Affine a = Affine::Identity();
    a.linear() = m;
    a.translation() = T[j] - m * S[j];
    maps.push_back(a);
  }
  const Skin move = Skin::automatic(x, names, found_frames, parents, Skin::kMaxInfluences, src);
  cloth::Vec3s fitted;
  move.apply(maps, x, fitted);

  // 5. Automatic weights at the bind pose.
  fit.body.source = src;
  fit.body.positions = fitted;
  fit.body.triangles = mesh.triangles;
  fit.body.skin = Skin::automatic(fitted, names, bind_frames, parents, Skin::kMaxInfluences, src);
  fit.body.bone_parent = parents;
  fit.body.rest_pose = bind_frames;
  fit.bind.resize(nj);
  for (int j = 0; j < nj; ++j) {
    fit.bind[j] = Transform::Identity();
    fit.bind[j].linear() = Q[j].toRotationMatrix();
    fit.bind[j].translation() = skeletal[j] ? T[j] : root_found;
  }
  fit.found = S;
  return fit;
}

BackCape make_back_cape(const BodyFit& fit, const Motion& motion, double width, double spacing, double gap,
                        double hem_max_distance, const std::string& source) {
  const double kMax = 100.0;  // m, larger than any body
  for (const auto& [name, v] :
       {std::pair<const char*, double>{"width", width}, {"spacing", spacing}, {"gap", gap}})
    if (!(v > 0.0 && v <= kMax)) throw Error(source, name, std::to_string(v) + " is not in (0, 100] m");
  if (!(hem_max_distance >= 0.0)) throw Error(source, "hem_max_distance", "must be >= 0 m");
  if (static_cast<int>(fit.bind.size()) != motion.num_joints())
    throw Error(source, "motion", "is not the motion the body was fitted to");
  const std::vector<std::string> canon = canonical_joint_names(motion);
  auto height = [&](const std::string& a, const std::string& b) {
    const int ja = find_canonical(canon, a), jb = find_canonical(canon, b);
    if (ja < 0 || jb < 0) throw Error(motion.source(), "joints", "no joint '" + (ja < 0 ? a : b) + "'");
    return 0.5 * (fit.bind[ja].translation().y() + fit.bind[jb].translation().y());
  };
  const double top = height("LeftArm", "RightArm"), bottom = height("LeftLeg", "RightLeg");
  BackCape c;
  c.columns = std::max(2, static_cast<int>(std::lround(width / spacing)) + 1);
  c.rows = std::max(2, static_cast<int>(std::floor((top - bottom) / spacing)) + 1);
  double mid = 0.0;
  for (const Vec3& p : fit.body.positions) mid += p.x();
  mid /= static_cast<double>(fit.body.positions.size());
  const double dx = width / (c.columns - 1);
  double z = std::numeric_limits<double>::infinity();
  for (int r = 0; r < c.rows; ++r) {
    const double y = top - r * spacing;
    for (const Vec3& p : fit.body.positions)
      if (std::abs(p.y() - y) < 0.5 * spacing && std::abs(p.x() - mid) < 0.5 * width) z = std::min(z, p.z());
    if (!std::isfinite(z)) throw Error(source, "width", "the cape's top row meets no part of the body");
    for (int k = 0; k < c.columns; ++k) c.positions.push_back(Vec3(mid - 0.5 * width + k * dx, y, z - gap));
    c.max_distance.insert(c.max_distance.end(), c.columns, hem_max_distance * r / (c.rows - 1));
  }
  for (int r = 0; r + 1 < c.rows; ++r)
    for (int k = 0; k + 1 < c.columns; ++k) {
      const int a = r * c.columns + k, b = a + 1, e = a + c.columns, g = e + 1;
      c.triangles.push_back({a, b, e});  // (x, -y) order: normal along -z, away from the body
      c.triangles.push_back({b, g, e});
    }
  c.skin = Skin::automatic(c.positions, fit.body.skin.bone_names(), fit.body.rest_pose, fit.body.bone_parent,
                           Skin::kMaxInfluences, source);
  return c;
}

std::map<std::string, double> body_capsule_radii(const BodyFit& fit, const Motion& motion, double quantile) {
  if (!(quantile >= 0.0 && quantile <= 1.0))
    throw Error(motion.source(), "quantile", std::to_string(quantile) + " is not in [0, 1]");
  const CapsuleRig rig = CapsuleRig::build(motion);
  const auto& bones = rig.bones();
  // Per bone: the distances of its nearest vertices, by side (0, 1: front and back, along the body's +z made
  // perpendicular to the bone; 2, 3: the two sides across it) and all together (4).
  std::vector<std::array<std::vector<double>, 5>> dist(bones.size());
  for (const Vec3& p : fit.body.positions) {
    double best = std::numeric_limits<double>::infinity();
    int which = -1;
    for (size_t k = 0; k < bones.size(); ++k) {
      if (bones[k].radius <= 0.0) continue;
      const double d = collision::point_segment_distance(p, fit.bind[bones[k].joint].translation(),
                                                         fit.bind[bones[k].child].translation());
      if (d < best) best = d, which = static_cast<int>(k);
    }
    if (which < 0) continue;
    const Vec3 a = fit.bind[bones[which].joint].translation(), e = fit.bind[bones[which].child].translation();
    const Vec3 u = (e - a).normalized();
    // Only vertices beside the segment (not beyond its ends, where the distance measures the caps).
    const double along = (p - a).dot(u);
    if (along <= 0.0 || along >= (e - a).norm()) continue;
    Vec3 front = Vec3::UnitZ() - Vec3::UnitZ().dot(u) * u;
    if (front.norm() < 0.1) front = Vec3::UnitX() - Vec3::UnitX().dot(u) * u;
    front.normalize();
    const Vec3 across = u.cross(front), r = p - a;
    const double f = r.dot(front), c = r.dot(across);
    const int side = std::abs(f) >= std::abs(c) ? (f >= 0.0 ? 0 : 1) : (c >= 0.0 ? 2 : 3);
    dist[which][side].push_back(best);
    dist[which][4].push_back(best);
  }
  auto quantile_of = [&](std::vector<double>& d) {
    const size_t q = std::min(d.size() - 1, static_cast<size_t>(quantile * static_cast<double>(d.size())));
    std::nth_element(d.begin(), d.begin() + static_cast<long>(q), d.end());
    return d[q];
  };
  std::map<std::string, double> radii;
  for (size_t k = 0; k < bones.size(); ++k) {
    if (dist[k][4].empty() || radii.count(bones[k].name)) continue;
    double r = quantile_of(dist[k][4]);
    // Torso, neck and head: the bone lies off the section's centre (a mocap spine runs close to the back),
    // so one radius around it cannot follow the surface on every side; the capsule takes its thinnest side
    // (of the sides holding at least 5 vertices and 2 % of the bone's), following the back.
    if (!kLimbBones.count(bones[k].canonical))
      for (int side = 0; side < 4; ++side)
        if (dist[k][side].size() >= std::max<size_t>(5, dist[k][4].size() / 50))
          r = std::min(r, quantile_of(dist[k][side]));
    radii[bones[k].name] = r;
  }
  return radii;
}

collision::ColliderSetPtr body_colliders(const BodyFit& fit, const Motion& motion) {
  return CapsuleRig::build(motion, body_capsule_radii(fit, motion)).clip_colliders(motion);
}

}  // namespace loom::characters
