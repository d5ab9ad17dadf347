#include "loom/characters/Garments.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/InputFile.h"
#include "loom/cloth/ObjFile.h"
#include "loom/collision/Distance.h"

namespace loom::characters {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRingClearance = 0.008;  // m, a skirt's attached waist ring to the pelvis capsules

struct Segment {
  Vec3 a, b;
  double r = 0.0;
  int bone = 0;
};

// The rig's capsules at t = 0 as world segments.
std::vector<Segment> segments_at_start(const Motion& motion, const CapsuleRig& rig,
                                       std::vector<Transform>& pose) {
  motion.pose(0.0, pose);
  std::vector<Segment> out;
  for (size_t k = 0; k < rig.bones().size(); ++k) {
    const Bone& b = rig.bones()[k];
    out.push_back({pose[b.joint].translation(), pose[b.child].translation(), b.radius, static_cast<int>(k)});
  }
  return out;
}

// Smallest gap from p to the capsule surfaces (negative inside).
double clearance_of(const Vec3& p, const std::vector<Segment>& caps) {
  double g = std::numeric_limits<double>::infinity();
  for (const Segment& s : caps) g = std::min(g, collision::point_segment_distance(p, s.a, s.b) - s.r);
  return g;
}

// Poses of the motion over the simulated time it plays (Motion::played_samples at 30 Hz of clip time).
std::vector<std::vector<Transform>> motion_samples(const Motion& motion) {
  const std::vector<double> times = motion.played_samples(30.0);
  std::vector<std::vector<Transform>> poses(times.size());
  for (std::size_t k = 0; k < times.size(); ++k) motion.pose(times[k], poses[k]);
  return poses;
}

// Smallest gap (m) between the capsules and a point carried rigidly by `joint` (at x0 when the pose is
// pose0), over the sampled poses.
double carried_gap(const Vec3& x0, int joint, const std::vector<Transform>& pose0, const CapsuleRig& rig,
                   const std::vector<std::vector<Transform>>& samples) {
  const Vec3 local = pose0[joint].inverse() * x0;
  double gap = std::numeric_limits<double>::infinity();
  for (const std::vector<Transform>& p : samples) {
    const Vec3 x = p[joint] * local;
    for (const Bone& bone : rig.bones())
      gap = std::min(gap, collision::point_segment_distance(x, p[bone.joint].translation(),
                                                            p[bone.child].translation()) -
                              bone.radius);
  }
  return gap;
}

// A grid of nu x nv vertices (row iv = 0 first); `wrap`: a tube closed along u. Corner uvs in metres
// (u: arc length along the row, v: down the garment), so warp runs down and weft around.
std::shared_ptr<const cloth::ClothMesh> grid_mesh(const cloth::Vec3s& x, int nu, int nv, bool wrap,
                                                  const std::string& source) {
  std::vector<cloth::Tri> tris;
  std::vector<std::array<cloth::Vec2, 3>> uvs;
  const int cols = wrap ? nu : nu - 1;
  // Rest uv of a vertex, arc length measured along the first row and down the first column.
  std::vector<double> u(nu + 1, 0.0), v(nv, 0.0);
  for (int i = 1; i <= nu; ++i) u[i] = u[i - 1] + (x[i % nu] - x[i - 1]).norm();
  for (int j = 1; j < nv; ++j) v[j] = v[j - 1] + (x[j * nu] - x[(j - 1) * nu]).norm();
  for (int j = 0; j + 1 < nv; ++j)
    for (int i = 0; i < cols; ++i) {
      const int i1 = (i + 1) % nu;
      const int a = j * nu + i, b = j * nu + i1, c = (j + 1) * nu + i, d = (j + 1) * nu + i1;
      const cloth::Vec2 ua(u[i], -v[j]), ub(u[i + 1], -v[j]), uc(u[i], -v[j + 1]), ud(u[i + 1], -v[j + 1]);
      if ((i + j) % 2 == 0) {
        tris.push_back({a, c, d});
        uvs.push_back({ua, uc, ud});
        tris.push_back({a, d, b});
        uvs.push_back({ua, ud, ub});
      } else {
        tris.push_back({a, c, b});
        uvs.push_back({ua, uc, ub});
        tris.push_back({b, c, d});
        uvs.push_back({ub, uc, ud});
      }
    }
  return cloth::ClothMesh::from_triangles(x, tris, uvs, source);
}

int joint_of(const CapsuleRig& rig, const std::string& canonical) {
  const int b = rig.find(canonical);
  return b < 0 ? -1 : rig.bones()[b].joint;
}

// The start joint of the bone nearest to p among bones whose canonical name is in `names` (all if empty).
int nearest_joint(const Vec3& p, const std::vector<Segment>& caps, const CapsuleRig& rig,
                  const std::set<std::string>& names) {
  double best = std::numeric_limits<double>::infinity();
  int joint = -1;
  for (const Segment& s : caps) {
    if (s.bone < 0 || (!names.empty() && !names.count(rig.bones()[s.bone].canonical))) continue;
    const double d = collision::point_segment_distance(p, s.a, s.b) - s.r;
    if (d < best) {
      best = d;
      joint = rig.bones()[s.bone].joint;
    }
  }
  return joint;
}

// Bones a skirt / a shirt goes around (arms and hands outside a skirt, hands outside a shirt).
const std::set<std::string> kSkirtBody = {"Hips",      "LowerBack",  "Spine",   "LHipJoint", "RHipJoint",
                                          "LeftUpLeg", "RightUpLeg", "LeftLeg", "RightLeg"};
const std::set<std::string> kShirtBody = {"Hips",      "LowerBack",    "Spine",         "Spine1",
                                          "Chest",     "Neck",         "Neck1",         "LHipJoint",
                                          "RHipJoint", "LeftShoulder", "RightShoulder", "LeftArm",
                                          "RightArm",  "LeftForeArm",  "RightForeArm"};
const std::set<std::string> kUpperTorso = {"Spine1", "Chest",        "Neck",
                                           "Neck1",  "LeftShoulder", "RightShoulder"};

}  // namespace

std::map<std::string, std::vector<int>> read_obj_groups(const std::string& path) {
  const cloth::ObjFile obj = cloth::read_obj_file(path);  // the one strict reader (ObjFile.h)
  std::map<std::string, std::set<int>> groups;
  for (const cloth::ObjFace& f : obj.faces)
    for (const cloth::ObjCorner& c : f.corners)
      for (const std::string& g : obj.groups[f.group]) groups[g].insert(c.v);
  std::map<std::string, std::vector<int>> out;
  for (const auto& [name, set] : groups) out[name] = std::vector<int>(set.begin(), set.end());
  return out;
}

namespace {

// What every garment builder reads: the spec, the motion and rig at t = 0 (`pose`, `caps`: the capsules as
// world segments plus the earlier layers' points to clear), and where errors are reported.
struct GarmentFit {
  GarmentFit(const GarmentSpec& s, const Motion& m, const CapsuleRig& r, const std::string& src,
             const std::string& w)
      : spec(s), motion(m), rig(r), source(src), where(w) {}

  // The joint of the bone `canonical`; throws naming the garment when the skeleton has none.
  int need(const std::string& canonical) const {
    const int j = joint_of(rig, canonical);
    const std::string removed = j < 0 ? rig.removed_by(canonical) : std::string();
    if (!removed.empty()) {
      const size_t g = where.find(".garments");
      throw RemovedCapsule(
          source, (g == std::string::npos ? std::string() : where.substr(0, g + 1)) + "radii." + removed,
          "the " + spec.type + " (" + where + ") hangs from the " + canonical +
              " capsule, which a radius of 0 removes; give it a radius > 0");
    }
    if (j < 0)
      throw Error(source, where,
                  "a " + spec.type + " needs a '" + canonical + "' bone in " + motion.source());
    return j;
  }
  double bone_radius(const std::string& canonical) const { return rig.bones()[rig.find(canonical)].radius; }
  // The grid mesh of x (grid_mesh), its errors reported at the garment's path.
  std::shared_ptr<const cloth::ClothMesh> mesh_of(const cloth::Vec3s& x, int nu, int nv, bool wrap) const {
    try {
      return grid_mesh(x, nu, nv, wrap, spec.type);
    } catch (const Error& e) {
      throw Error(source, where, e.what());
    }
  }

  const GarmentSpec& spec;
  const Motion& motion;
  const CapsuleRig& rig;
  const std::string& source;
  const std::string& where;
  std::vector<Transform> pose;  // the motion's global joint transforms at t = 0
  std::vector<Segment> caps;    // the rig's capsules at t = 0, then the points of earlier layers (radius 0)
};

const Vec3 kUp = Vec3::UnitY();

// A cape: one vertical plane behind the back, its top row attached to the chest.
Garment make_cape(const GarmentFit& f) {
  const GarmentSpec& spec = f.spec;
  const std::vector<Transform>& pose = f.pose;
  Garment g;
  const Vec3 ls = pose[f.need("LeftArm")].translation(), rs = pose[f.need("RightArm")].translation();
  const Vec3 knee = pose[f.need("LeftLeg")].translation();
  Vec3 right = rs - ls;
  right.y() = 0.0;
  if (right.norm() < 1e-9) throw Error(f.source, f.where, "the shoulders coincide at t = 0");
  right.normalize();
  const Vec3 forward = kUp.cross(right);
  const double top = std::max(ls.y(), rs.y());
  Vec3 centre = 0.5 * (ls + rs);
  centre.y() = top;
  const double width = spec.width > 0.0 ? spec.width : (rs - ls).norm() + 0.2;
  const double length = spec.length > 0.0 ? spec.length : top - knee.y();
  if (!(length > 0.0))
    throw Error(f.source, f.where + ".length", "the knees are above the shoulders at t = 0");
  const int nu = std::max(3, static_cast<int>(std::ceil(width / spec.resolution)) + 1);
  const int nv = std::max(3, static_cast<int>(std::ceil(length / spec.resolution)) + 1);
  cloth::Vec3s x(nu * nv);
  // One vertical plane behind the back, as close as the capsules allow; its attached top row must also
  // clear every capsule at every pose of the motion (an attached vertex cannot be pushed out by contacts:
  // inside a lifted arm it would squeeze the free cloth next to it, as a thigh does to a skirt's waist).
  const auto samples = motion_samples(f.motion);
  // The whole top row hangs from one frame, the chest (the neck's parent joint): attached to the nearest of
  // the neck and clavicle bones, neighbouring pins on different bones would stretch the edge between them
  // whenever the shoulders move against the neck.
  const int chest = f.motion.joints()[f.need("Neck")].parent;
  if (chest < 0) throw Error(f.source, f.where, "the neck has no parent joint in " + f.motion.source());
  double static_depth = -1.0;
  for (double depth = 0.0;; depth += 0.002) {
    bool clear = true;
    for (int j = 0; j < nv && clear; ++j)
      for (int i = 0; i < nu && clear; ++i) {
        x[j * nu + i] = centre + (-0.5 * width + width * i / (nu - 1)) * right -
                        (length * j / (nv - 1)) * kUp - depth * forward;
        clear = clearance_of(x[j * nu + i], f.caps) >= spec.clearance;
      }
    if (clear && static_depth < 0.0) static_depth = depth;
    for (int i = 0; i < nu && clear && depth < static_depth + 0.3; ++i)
      clear = carried_gap(x[i], chest, pose, f.rig, samples) >= spec.clearance;
    if (clear || depth > 2.0 || (static_depth >= 0.0 && depth >= static_depth + 0.3)) break;
  }
  g.mesh = f.mesh_of(x, nu, nv, false);
  for (int i = 0; i < nu; ++i) {
    g.attached_vertices.push_back(i);
    g.attached_joints.push_back(chest);
  }
  return g;
}

// The top ring and extent of a tube garment (skirt or shirt) at t = 0.
struct TubeFrame {
  double top = 0.0, bottom = 0.0;  // m, heights of the top and bottom rings
  double a = 0.0, b = 0.0;         // m, semi-axes of the top ring (a along `right`, b along forward)
  Vec3 centre = Vec3::Zero();      // the axis passes through it (vertical)
  Vec3 right = Vec3::UnitX();      // horizontal unit vector, left to right
};

// A skirt's frame: the waist ring above the thighs' capsules where they leave the pelvis, down to the knees.
TubeFrame skirt_frame(const GarmentFit& f) {
  const std::vector<Transform>& pose = f.pose;
  const int root = f.motion.root();
  const Vec3 hips = pose[root].translation();
  TubeFrame t;
  const Vec3 knee = pose[f.need("LeftLeg")].translation();
  // The waist ring sits above the thighs' capsules where they leave the pelvis, so that a raised knee
  // does not sweep through the pinned ring (Biovision hips are level with the root, CMU's 12 cm below).
  double lift = 0.0;  // m, above the root
  for (const char* leg : {"LeftUpLeg", "RightUpLeg"}) {
    f.need(leg);
    const Bone& thigh = f.rig.bones()[f.rig.find(leg)];
    const double hip = (pose[root].inverse() * pose[thigh.joint].translation()).y();
    lift = std::max(lift, hip + thigh.radius + kRingClearance);
  }
  t.top = hips.y() + lift;
  t.bottom = f.spec.length > 0.0 ? t.top - f.spec.length : knee.y();
  t.centre = hips;
  t.a = t.b = 0.1;
  Vec3 right = pose[f.need("RightUpLeg")].translation() - pose[f.need("LeftUpLeg")].translation();
  right.y() = 0.0;
  t.right = right.norm() > 1e-9 ? right.normalized() : Vec3::UnitX();
  return t;
}

// A shirt's frame: the shoulder ring (as wide as the shoulders plus the upper arm), down to the hips.
TubeFrame shirt_frame(const GarmentFit& f) {
  const std::vector<Transform>& pose = f.pose;
  const Vec3 hips = pose[f.motion.root()].translation();
  TubeFrame t;
  const Vec3 ls = pose[f.need("LeftArm")].translation(), rs = pose[f.need("RightArm")].translation();
  Vec3 right = rs - ls;
  right.y() = 0.0;
  if (right.norm() < 1e-9) throw Error(f.source, f.where, "the shoulders coincide at t = 0");
  right.normalize();
  t.right = right;
  t.top = std::max(ls.y(), rs.y());
  t.bottom = f.spec.length > 0.0 ? t.top - f.spec.length : hips.y();
  t.centre = 0.5 * (ls + rs);
  t.a = 0.5 * (rs - ls).norm() + f.bone_radius("LeftArm") + f.spec.clearance;
  t.b = 0.12;
  return t;
}

// How far (m) the ray axis + r dir, r in [0, 1.5), runs within `gap` of the `avoid` capsules: the farthest r
// still too close. For the pinned ring (`ring`), further out until the point, carried rigidly by the root,
// also clears the torso by `gap` at every sampled pose (a spine bending forward over it).
double ray_reach(const GarmentFit& f, const Vec3& axis, const Vec3& dir, const std::vector<Segment>& avoid,
                 double gap, bool ring, const std::vector<Segment>& torso,
                 const std::vector<std::vector<Transform>>& samples) {
  const int root = f.motion.root();
  double last = 0.0;  // m, farthest point of the ray still within clearance of the body
  for (double r = 0.0; r < 1.5; r += 0.002)
    if (clearance_of(axis + r * dir, avoid) < gap) last = r;
  while (ring && last < 1.5) {
    const Vec3 local = f.pose[root].inverse() * (axis + (last + 0.002) * dir);
    bool clear = true;
    for (size_t k = 0; k < samples.size() && clear; ++k)
      for (const Segment& c : torso)
        if (c.bone >= 0) {
          const Bone& bone = f.rig.bones()[c.bone];
          const std::vector<Transform>& p = samples[k];
          if (collision::point_segment_distance(p[root] * local, p[bone.joint].translation(),
                                                p[bone.child].translation()) -
                  bone.radius <
              gap) {
            clear = false;
            break;
          }
        }
    if (clear) break;
    last += 0.002;
  }
  return last;
}

// Smooth rings (edges must not cut capsules): the largest need within +-22.5 degrees, then the mean over the
// same window (never below any need within it).
void smooth_ring(std::vector<double>& need) {
  const int trial = static_cast<int>(need.size());
  const int w = trial / 16;
  std::vector<double> wide(trial, 0.0);
  for (int i = 0; i < trial; ++i)
    for (int m = -w; m <= w; ++m) wide[i] = std::max(wide[i], need[(i + m + trial) % trial]);
  for (int i = 0; i < trial; ++i) {
    double sum = 0.0;
    for (int m = -w; m <= w; ++m) sum += wide[(i + m + trial) % trial];
    need[i] = sum / (2 * w + 1);
  }
}

// A skirt or a shirt: rings from the top ring down, each the top ellipse scaled about the axis (ring_scales),
// the top ring attached (a skirt's to the root, a shirt's to the nearest upper-torso bone).
Garment make_tube(const GarmentFit& f) {
  const GarmentSpec& spec = f.spec;
  const bool skirt = spec.type == "skirt";
  const int root = f.motion.root();
  const TubeFrame fr = skirt ? skirt_frame(f) : shirt_frame(f);
  const double top = fr.top, bottom = fr.bottom, a = fr.a, b = fr.b;
  const Vec3 centre = fr.centre, right = fr.right;
  if (!(top - bottom > 0.0)) throw Error(f.source, f.where + ".length", "the garment has no length at t = 0");
  const Vec3 forward = kUp.cross(right);
  const std::set<std::string>& set = skirt ? kSkirtBody : kShirtBody;
  const int nv = std::max(3, static_cast<int>(std::ceil((top - bottom) / spec.resolution)) + 1);
  // Each ring is the top ellipse scaled about the axis: by `flare` towards the hem (skirt), and at least so
  // far that every ray from the axis has left the body's capsules (the garment's set) `clearance` before
  // the ring; a ring is never smaller than the one above it. Smooth rings, so edges do not cut capsules.
  // ... plus any other capsule with an end inside the garment's height (hanging hands, a boxer's forearms).
  // The attached top ring of a skirt clears the pelvis and thighs only, and closely (`ring_clearance`):
  // the arms swing past the hips (CapsuleRig::fit_to_motion keeps them capsule_gap away from the body), and
  // a pinned ring pushed out around the hanging hands at t = 0 would sit where the arms pass.
  std::vector<Segment> body, torso;
  auto within = [&](const Vec3& p) { return p.y() > bottom && p.y() < top - 0.05; };
  for (const Segment& c : f.caps) {
    const bool own = c.bone < 0 || set.count(f.rig.bones()[c.bone].canonical);
    // A skirt's rows go inside the arms (CapsuleRig::fit_to_motion leaves room between arms and body).
    if (own || (!skirt && (within(c.a) || within(c.b)))) body.push_back(c);
    if (own) torso.push_back(c);
  }
  const int trial = 96;
  const auto samples = skirt ? motion_samples(f.motion) : std::vector<std::vector<Transform>>{};
  // Scale of each ring in each of the `trial` directions. A shirt's rings are ellipses (one scale per
  // ring); a skirt's are star-shaped, each direction only as far out as it needs: a round ring as wide as
  // the widest direction needs (the belly side when the spine bends forward over it) would sit where the
  // arms hang at the sides, inside the upper arms.
  std::vector<std::vector<double>> scale(nv, std::vector<double>(trial, 1.0));
  for (int j = 0; j < nv; ++j) {
    const double s = static_cast<double>(j) / (nv - 1);
    const Vec3 axis(centre.x(), top - s * (top - bottom), centre.z());
    const double flare = skirt ? 1.0 + (spec.flare - 1.0) * s : 1.0;
    std::vector<double> need(trial, flare);
    const bool ring = skirt && j == 0;
    const std::vector<Segment>& avoid = ring ? torso : body;
    // m; 5 mm for the chords; a skirt stays within 1.5 cm of the body, inside the arms hanging 2 cm away
    const double gap = ring ? std::min(spec.clearance, kRingClearance)
                            : (skirt ? std::min(spec.clearance, 0.01) : spec.clearance) + 0.005;
    for (int i = 0; i < trial; ++i) {
      const double th = 2.0 * kPi * i / trial;
      const Vec3 dir = std::cos(th) * right + std::sin(th) * forward;
      const double base = std::hypot(a * std::cos(th), b * std::sin(th));
      const double last = ray_reach(f, axis, dir, avoid, gap, ring, torso, samples);
      need[i] = std::max(need[i], (last + 0.002) / base);
    }
    if (skirt) {
      smooth_ring(need);
    } else {
      need.assign(trial, *std::max_element(need.begin(), need.end()));
    }
    for (int i = 0; i < trial; ++i) scale[j][i] = j == 0 ? need[i] : std::max(need[i], scale[j - 1][i]);
  }
  // Scale at angle th, interpolated between the trial directions.
  auto scale_at = [&](int j, double th) {
    const double u0 = th / (2.0 * kPi) * trial;
    const int i0 = static_cast<int>(std::floor(u0)) % trial;
    const double u = u0 - std::floor(u0);
    return (1.0 - u) * scale[j][i0] + u * scale[j][(i0 + 1) % trial];
  };
  auto ring_point = [&](int j, double th) {
    return scale_at(j, th) * (a * std::cos(th) * right + b * std::sin(th) * forward);
  };
  // Points around from the longest ring, so edges are about `resolution` long.
  double perimeter = 0.0;
  for (int i = 0; i < trial; ++i)
    perimeter +=
        (ring_point(nv - 1, 2.0 * kPi * (i + 1) / trial) - ring_point(nv - 1, 2.0 * kPi * i / trial)).norm();
  const int nu = std::max(8, static_cast<int>(std::ceil(perimeter / spec.resolution)));
  cloth::Vec3s x(nu * nv);
  for (int j = 0; j < nv; ++j) {
    const double y = top - (static_cast<double>(j) / (nv - 1)) * (top - bottom);
    for (int i = 0; i < nu; ++i)
      x[j * nu + i] = Vec3(centre.x(), y, centre.z()) + ring_point(j, 2.0 * kPi * i / nu);
  }
  Garment g;
  g.mesh = f.mesh_of(x, nu, nv, true);
  for (int i = 0; i < nu; ++i) {
    g.attached_vertices.push_back(i);
    g.attached_joints.push_back(skirt ? root : nearest_joint(x[i], f.caps, f.rig, kUpperTorso));
  }
  return g;
}

// A garment from an OBJ file, its vertex groups attached to named bones (or each vertex to the nearest).
Garment make_obj_garment(const GarmentFit& f) {
  const GarmentSpec& spec = f.spec;
  Garment g;
  try {
    g.mesh = cloth::ClothMesh::from_obj(spec.path, spec.scale, spec.translate);
  } catch (const Error& e) {
    throw Error(f.source, f.where, e.what());
  }
  const auto groups = read_obj_groups(spec.path);
  const std::vector<std::string> canon = canonical_joint_names(f.motion);
  std::vector<char> attached(g.mesh->num_vertices(), 0);  // a vertex in several groups is attached once
  for (const auto& [group, bone] : spec.attach) {
    auto it = groups.find(group);
    if (it == groups.end())
      throw Error(f.source, f.where + ".attach." + group, "no group '" + group + "' in " + spec.path);
    int joint = -1;
    if (bone != "nearest") {
      for (int k = 0; k < f.motion.num_joints() && joint < 0; ++k)
        if (f.motion.joints()[k].name == bone || canon[k] == bone) joint = k;
      if (joint < 0)
        throw Error(f.source, f.where + ".attach." + group, "no bone '" + bone + "' in " + f.motion.source());
    }
    for (int v : it->second) {
      if (attached[v]) continue;
      attached[v] = 1;
      g.attached_vertices.push_back(v);
      g.attached_joints.push_back(joint >= 0 ? joint
                                             : nearest_joint(g.mesh->rest_positions()[v], f.caps, f.rig, {}));
    }
  }
  return g;
}

}  // namespace

Garment make_garment(const GarmentSpec& spec, const Motion& motion, const CapsuleRig& rig,
                     const std::string& source, const std::string& where, const cloth::Vec3s& outside) {
  if (!(spec.resolution > 0.0)) throw Error(source, where + ".resolution", "must be > 0");
  if (!(spec.clearance >= 0.0)) throw Error(source, where + ".clearance", "must be >= 0");
  GarmentFit f(spec, motion, rig, source, where);
  f.caps = segments_at_start(motion, rig, f.pose);
  for (const Vec3& p : outside) f.caps.push_back({p, p, 0.0, -1});  // earlier layers: points to clear
  Garment g;
  if (spec.type == "cape") {
    g = make_cape(f);
  } else if (spec.type == "skirt" || spec.type == "shirt") {
    g = make_tube(f);
  } else if (spec.type == "obj") {
    g = make_obj_garment(f);
  } else {
    throw Error(source, where + ".type",
                "unknown garment '" + show_value(spec.type) + "' (known: cape, skirt, shirt, obj)");
  }
  for (int j : g.attached_joints)
    if (j < 0) throw Error(source, where, "no bone to attach the " + spec.type + " to");
  return g;
}

}  // namespace loom::characters
