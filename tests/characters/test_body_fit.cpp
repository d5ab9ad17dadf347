// BodyFit: MakeHuman's base mesh (tests/data/body/human.zae, from assimp's test models) fitted and skinned
// to the CMU skeleton of tests/data/mocap/01_01.bvh, driven by the clip.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>

#include "CharacterTestUtil.h"
#include "TestDir.h"
#include "loom/characters/BodyFit.h"
#include "loom/characters/GarmentInstance.h"
#include "loom/cloth/Error.h"
#include "loom/collision/Distance.h"

using namespace loom::characters;
using loom::cloth::Tri;
using loom::cloth::Vec3;
using loom::cloth::Vec3s;

namespace {

std::string body_path() { return std::string(LOOM_TEST_DATA) + "/body/human.zae"; }

template <class F>
void expect_error(F f, const std::string& field, const std::string& problem) {
  try {
    f();
    FAIL() << "no error for " << field;
  } catch (const loom::Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(field), std::string::npos) << m;
    EXPECT_NE(m.find(problem), std::string::npos) << m;
  }
}

// A closed tube of radius r around the segment a -> b (n sides, m rings), capped by a fan at each end.
void add_tube(const Vec3& a, const Vec3& b, double r, int n, int m, Vec3s& x, std::vector<Tri>& tris) {
  const Vec3 axis = (b - a).normalized();
  const Vec3 u = axis.unitOrthogonal(), v = axis.cross(u);
  const int base = static_cast<int>(x.size());
  for (int k = 0; k <= m; ++k)
    for (int i = 0; i < n; ++i) {
      const double phi = 2 * M_PI * i / n;
      x.push_back(a + (b - a) * k / m + r * (std::cos(phi) * u + std::sin(phi) * v));
    }
  for (int k = 0; k < m; ++k)
    for (int i = 0; i < n; ++i) {
      const int p = base + k * n + i, q = base + k * n + (i + 1) % n;
      tris.push_back({p, q, q + n});
      tris.push_back({p, q + n, p + n});
    }
  const int c0 = static_cast<int>(x.size()), c1 = c0 + 1;
  x.push_back(a);
  x.push_back(b);
  for (int i = 0; i < n; ++i) {
    tris.push_back({c0, base + (i + 1) % n, base + i});
    tris.push_back({c1, base + m * n + i, base + m * n + (i + 1) % n});
  }
}

// The loop of the section through `point` (normal `normal`) whose centroid is nearest to `point`.
SectionLoop nearest_loop(const Vec3s& x, const std::vector<Tri>& tris, const Vec3& point,
                         const Vec3& normal) {
  SectionLoop best;
  double d = std::numeric_limits<double>::infinity();
  for (const SectionLoop& l : mesh_section(x, tris, point, normal))
    if ((l.centroid - point).norm() < d) d = (l.centroid - point).norm(), best = l;
  return best;
}

struct Fitted {
  Motion motion;
  BodyFit fit;
};

const Fitted& fitted() {
  static const Fitted f = [] {
    Motion m = Motion::load(loom::test::mocap("01_01.bvh"));
    BodyFit fit = fit_body(load_static_mesh(body_path(), 0), m);
    return Fitted{std::move(m), std::move(fit)};
  }();
  return f;
}

int joint(const Motion& m, const std::string& name) {
  const int j = m.find(name);
  EXPECT_GE(j, 0) << name;
  return j;
}

// The fitted body skinned at simulated time t of the clip.
Vec3s body_at(const Fitted& f, double t) {
  std::vector<Transform> g;
  f.motion.pose(t, g);
  std::vector<Affine> pose, m;
  pose_from_motion(match_bones(f.fit.body.skin, f.motion), g, pose);
  f.fit.body.skin.skinning_matrices(pose, m);
  Vec3s x;
  f.fit.body.skin.apply(m, f.fit.body.positions, x);
  return x;
}

constexpr double kCapeThickness = 0.005;  // m, the cape's contact thickness against the body's capsules

// The cape of make_back_cape (0.5 m wide, 5 cm grid, 3 cm behind the back, max distance 0 at the shoulders
// to 0.3 m at the hem) with a backstop plane 1 cm behind its skinned surface and a coat fabric.
struct BodyCape {
  BackCape cape;
  GarmentSettings settings;
};

BodyCape make_body_cape(const Fitted& f) {
  BodyCape c{make_back_cape(f.fit, f.motion), {}};
  c.settings.constraints.max_distance = c.cape.max_distance;
  c.settings.constraints.backstop_distance.assign(c.cape.positions.size(), 0.01);
  c.settings.material.bend_weft = c.settings.material.bend_warp = 1e-4;
  c.settings.material.damping = 0.05;
  return c;
}

std::vector<Affine> bones_at(const Fitted& f, double t) {
  std::vector<Transform> g;
  f.motion.pose(t, g);
  std::vector<Affine> pose;
  pose_from_motion(match_bones(f.fit.body.skin, f.motion), g, pose);
  return pose;
}

}  // namespace

TEST(MeshSection, LoopsOfTubesAreCentredOnTheirAxes) {
  Vec3s x;
  std::vector<Tri> tris;
  add_tube(Vec3(0, 0, 0), Vec3(0, 1, 0), 0.1, 64, 8, x, tris);
  add_tube(Vec3(0.5, 0, 0), Vec3(0.7, 1, 0.1), 0.05, 48, 8, x, tris);
  // A horizontal cut: two loops; the vertical tube's is a 64-gon of circumradius 0.1 around the axis.
  auto loops = mesh_section(x, tris, Vec3(0, 0.43, 0), Vec3::UnitY());
  ASSERT_EQ(loops.size(), 2u);
  EXPECT_NEAR((loops[0].centroid - Vec3(0, 0.43, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(loops[0].perimeter, 64 * 2 * 0.1 * std::sin(M_PI / 64), 1e-12);
  // The slanted tube cut by a horizontal plane: an ellipse centred on the axis.
  const Vec3 axis_point = Vec3(0.5, 0, 0) + 0.43 * Vec3(0.2, 1, 0.1);
  EXPECT_NEAR((loops[1].centroid - axis_point).norm(), 0.0, 1e-9);
  // A tilted plane through the vertical tube.
  loops = mesh_section(x, tris, Vec3(0, 0.5, 0), Vec3(0.3, 1, -0.2));
  ASSERT_GE(loops.size(), 1u);
  EXPECT_NEAR((loops[0].centroid - Vec3(0, 0.5, 0)).norm(), 0.0, 1e-9);
}

// "Joint positions of the fitted mesh", measured on the fitted mesh alone with the planes of the bind pose's
// bones (the fit itself works on horizontal sections of the unfitted mesh):
//   knees, elbows: centroid of the section through the joint normal to the bisector of its two bones;
//   wrists: centroid of the section through the joint normal to the forearm;
//   hips, shoulders (inside the pelvis and the shoulder, where no section rings a limb): distance from the
//   joint to the limb's axis, the line through the centroids of the thigh's (upper arm's) sections at 40 %
//   and 70 % of the bone;
//   ankles (a section through the ankle also cuts the heel and the instep): distance from the joint to the
//   shin's axis, the line through the centroids of the shin's sections at 50 % and 80 % of the bone.
TEST(BodyFit, FittedJointsSitInTheBodysSections) {
  const Fitted& f = fitted();
  const BodyFit& fit = f.fit;
  const Motion& m = f.motion;
  EXPECT_GT(fit.body.positions.size(), 13000u);
  EXPECT_EQ(fit.measured.size(), 12u);
  const auto& x = fit.body.positions;
  const auto& tris = fit.body.triangles;
  auto at = [&](const std::string& n) { return Vec3(fit.bind[joint(m, n)].translation()); };
  auto report = [](const std::string& j, double d, double limit) {
    std::printf("%-13s %.4f m (limit %.3f)\n", j.c_str(), d, limit);
    EXPECT_LT(d, limit) << j;
  };
  for (const char* side : {"Left", "Right"}) {
    const std::string s = side;
    for (const auto& [a, j, c] :
         std::vector<std::array<std::string, 3>>{{s + "UpLeg", s + "Leg", s + "Foot"},
                                                 {s + "Leg", s + "Foot", s + "ToeBase"},
                                                 {s + "Arm", s + "ForeArm", s + "Hand"}}) {
      const Vec3 n = (at(j) - at(a)).normalized() + (at(c) - at(j)).normalized();
      if (j != s + "Foot") report(j, (nearest_loop(x, tris, at(j), n).centroid - at(j)).norm(), 0.01);
    }
    const Vec3 forearm = at(s + "Hand") - at(s + "ForeArm");
    report(s + "Hand", (nearest_loop(x, tris, at(s + "Hand"), forearm).centroid - at(s + "Hand")).norm(),
           0.01);
    auto to_axis = [&](const Vec3& a, const Vec3& n, double f1, double f2, const Vec3& q) {
      const Vec3 p1 = nearest_loop(x, tris, a + f1 * n, n).centroid;
      const Vec3 p2 = nearest_loop(x, tris, a + f2 * n, n).centroid;
      const Vec3 d = (p2 - p1).normalized();
      return ((q - p1) - (q - p1).dot(d) * d).norm();
    };
    for (const auto& [j, c] : std::vector<std::pair<std::string, std::string>>{{s + "UpLeg", s + "Leg"},
                                                                               {s + "Arm", s + "ForeArm"}})
      report(j, to_axis(at(j), at(c) - at(j), 0.4, 0.7, at(j)), 0.01);
    report(s + "Foot", to_axis(at(s + "Leg"), at(s + "Foot") - at(s + "Leg"), 0.5, 0.8, at(s + "Foot")),
           0.01);
  }
}

TEST(BodyFit, SkinnedBodyFollowsTheClip) {
  const Fitted& f = fitted();
  const Motion& m = f.motion;
  const auto& tris = f.fit.body.triangles;
  // Sections at 30 % and 70 % of each limb bone keep their distance (the segment does not stretch), and the
  // knee's and elbow's sections stay around their joints.
  const std::vector<std::pair<std::string, std::string>> bones = {
      {"LeftUpLeg", "LeftLeg"},     {"LeftLeg", "LeftFoot"},      {"RightUpLeg", "RightLeg"},
      {"RightLeg", "RightFoot"},    {"LeftArm", "LeftForeArm"},   {"LeftForeArm", "LeftHand"},
      {"RightArm", "RightForeArm"}, {"RightForeArm", "RightHand"}};
  auto span = [&](const Vec3s& x, const std::vector<Transform>& g, const std::string& a,
                  const std::string& b) {
    const Vec3 pa = g[joint(m, a)].translation(), pb = g[joint(m, b)].translation(), n = pb - pa;
    return (nearest_loop(x, tris, pa + 0.7 * n, n).centroid - nearest_loop(x, tris, pa + 0.3 * n, n).centroid)
        .norm();
  };
  std::vector<Transform> bind(f.fit.bind.begin(), f.fit.bind.end());
  std::vector<double> rest;
  for (const auto& [a, b] : bones) rest.push_back(span(f.fit.body.positions, bind, a, b));
  double worst_stretch = 0, worst_joint = 0;
  for (double t = 0.5; t < std::min(m.duration(), 20.0); t += 1.5) {
    const Vec3s x = body_at(f, t);
    ASSERT_TRUE(std::all_of(x.begin(), x.end(), [](const Vec3& p) { return p.allFinite(); })) << t;
    std::vector<Transform> g;
    m.pose(t, g);
    for (size_t k = 0; k < bones.size(); ++k)
      worst_stretch =
          std::max(worst_stretch, std::abs(span(x, g, bones[k].first, bones[k].second) / rest[k] - 1));
    for (const char* side : {"Left", "Right"}) {
      const std::string s = side;
      for (const auto& [a, j, c] : std::vector<std::array<std::string, 3>>{
               {s + "UpLeg", s + "Leg", s + "Foot"}, {s + "Arm", s + "ForeArm", s + "Hand"}}) {
        const Vec3 pa = g[joint(m, a)].translation(), pj = g[joint(m, j)].translation(),
                   pc = g[joint(m, c)].translation();
        const Vec3 n = (pj - pa).normalized() + (pc - pj).normalized();
        worst_joint = std::max(worst_joint, (nearest_loop(x, tris, pj, n).centroid - pj).norm());
      }
    }
  }
  std::printf("clip: worst limb stretch %.4f, worst knee/elbow section offset %.4f m\n", worst_stretch,
              worst_joint);
  EXPECT_LT(worst_stretch, 0.03);
  EXPECT_LT(worst_joint, 0.03);
}

TEST(BodyFit, CapsuleRadiiMatchTheBodysSections) {
  const Fitted& f = fitted();
  const Motion& m = f.motion;
  const auto radii = body_capsule_radii(f.fit, m);
  for (const auto& [name, r] : radii) std::printf("radius %-14s %.4f\n", name.c_str(), r);
  // Limb capsules: radius within 25 % of the equivalent radius (perimeter / 2 pi) of the section at mid-bone.
  for (const auto& [a, b] : std::vector<std::pair<std::string, std::string>>{{"LeftUpLeg", "LeftLeg"},
                                                                             {"LeftLeg", "LeftFoot"},
                                                                             {"LeftArm", "LeftForeArm"},
                                                                             {"LeftForeArm", "LeftHand"},
                                                                             {"RightUpLeg", "RightLeg"},
                                                                             {"RightArm", "RightForeArm"}}) {
    const Vec3 pa = f.fit.bind[joint(m, a)].translation(), pb = f.fit.bind[joint(m, b)].translation();
    const double section =
        nearest_loop(f.fit.body.positions, f.fit.body.triangles, 0.5 * (pa + pb), pb - pa).perimeter /
        (2 * M_PI);
    ASSERT_TRUE(radii.count(a)) << a;
    std::printf("%s: capsule %.4f, section %.4f\n", a.c_str(), radii.at(a), section);
    EXPECT_NEAR(radii.at(a), section, 0.25 * section) << a;
  }
  // The radii are CapsuleRig overrides: a rig built with them has them.
  const CapsuleRig rig = CapsuleRig::build(m, radii);
  int overridden = 0;
  for (const Bone& b : rig.bones())
    if (radii.count(b.name)) {
      EXPECT_EQ(b.radius, radii.at(b.name)) << b.name;
      ++overridden;
    }
  EXPECT_GE(overridden, 20);
  // The rig at the bind pose: the fraction of vertices far outside every capsule, and the torso capsules'
  // backs (where a cape lies) are within 2 cm of the back of the body's section through the middle of the
  // bone, never outside it by more than 1 cm.
  const auto& x = f.fit.body.positions;
  auto surface_distance = [&](const Vec3& p, const Bone& b) {
    return loom::collision::point_segment_distance(p, f.fit.bind[b.joint].translation(),
                                                   f.fit.bind[b.child].translation()) -
           b.radius;
  };
  int far_out = 0;
  for (const Vec3& p : x) {
    double d = std::numeric_limits<double>::infinity();
    for (const Bone& b : rig.bones())
      if (b.radius > 0.0) d = std::min(d, surface_distance(p, b));
    if (d > 0.04) ++far_out;
  }
  const double far_fraction = static_cast<double>(far_out) / static_cast<double>(x.size());
  std::printf("body vertices more than 4 cm outside every capsule: %.4f\n", far_fraction);
  // The torso's capsules are inscribed from the back (the thinnest side): the chest and belly lie outside
  // them, about a quarter of the body's vertices. The bound keeps the rest of the rig on the body.
  EXPECT_LT(far_fraction, 0.3);
  for (const char* name : {"LowerBack", "Spine"}) {
    ASSERT_GE(rig.find(name), 0) << name;
    const Bone& b = rig.bones()[rig.find(name)];
    const Vec3 pa = f.fit.bind[b.joint].translation(), pb = f.fit.bind[b.child].translation();
    const Vec3 mid = 0.5 * (pa + pb);
    const SectionLoop l = nearest_loop(x, f.fit.body.triangles, mid, pb - pa);
    const double capsule_back = mid.z() - b.radius;  // the bones are near vertical: the back is along -z
    std::printf("%s: capsule back z %.4f, body back z %.4f\n", name, capsule_back, l.lo.z());
    EXPECT_GT(capsule_back - l.lo.z(), -0.01) << name;
    EXPECT_LT(capsule_back - l.lo.z(), 0.02) << name;
  }
  expect_error([&] { body_capsule_radii(f.fit, m, 1.5); }, "quantile", "not in [0, 1]");
}

TEST(BodyFit, SkinnedCapeOnTheBodyKeepsItsConstraintsThroughTheClip) {
  const Fitted& f = fitted();
  const BodyCape c = make_body_cape(f);
  const int columns = c.cape.columns, rows = c.cape.rows;
  // Normals point away from the body: the cape's first triangle faces -z.
  const Tri& t0 = c.cape.triangles[0];
  const Vec3s& p = c.cape.positions;
  EXPECT_LT((p[t0[1]] - p[t0[0]]).cross(p[t0[2]] - p[t0[0]]).z(), 0.0);
  GarmentInstance g(c.cape.positions, c.cape.triangles, c.cape.skin, c.settings, bones_at(f, 0.0), "cape");
  GarmentInstance bare(c.cape.positions, c.cape.triangles, c.cape.skin, c.settings, bones_at(f, 0.0), "cape");
  double bare_over = 0, bare_behind = 0;
  // The body's capsules (radii fitted to it) move with the clip and collide with the cape after its
  // constraints (GarmentInstance step 5).
  const auto colliders = body_colliders(f.fit, f.motion);
  loom::collision::RealtimeContactSettings contact;
  contact.thickness = kCapeThickness;
  g.set_colliders(colliders, contact);
  double worst_over = 0, worst_behind = 0, hem_motion = 0, top_error = 0, deepest = 0, deepest_pinned = 0;
  const CapsuleRig rig = CapsuleRig::build(f.motion, body_capsule_radii(f.fit, f.motion));
  ASSERT_EQ(colliders->size(), rig.bones().size());
  std::vector<Transform> joints;
  // Deepest vertex (free ones, and the kinematic top row apart) inside a capsule at simulated time t.
  auto depth = [&](const Vec3s& x, double t, double* pinned) {
    f.motion.pose(t, joints);
    double d = 0;
    for (size_t i = 0; i < x.size(); ++i)
      for (const Bone& b : rig.bones()) {
        const double di = b.radius - loom::collision::point_segment_distance(
                                         x[i], joints[b.joint].translation(), joints[b.child].translation());
        if (c.cape.max_distance[i] > 0.0)
          d = std::max(d, di);
        else if (pinned)
          *pinned = std::max(*pinned, di);
      }
    return d;
  };
  const double deepest_at_start = depth(g.positions(), 0.0, nullptr);
  for (int k = 1; k <= 180; ++k) {
    const double t = k / 60.0;
    g.set_pose(bones_at(f, t));
    g.step(1.0 / 60.0);
    bare.set_pose(bones_at(f, t));
    bare.step(1.0 / 60.0);
    for (int i = 0; i < bare.num_vertices(); ++i) {
      const Vec3& q = bare.positions()[i];
      bare_over =
          std::max(bare_over, (q - bare.targets()[i]).norm() - c.settings.constraints.max_distance[i]);
      bare_behind = std::max(
          bare_behind, bare.constraints().backstop_depth(i, q, bare.targets()[i], bare.target_normals()[i]));
    }
    const Vec3s& x = g.positions();
    deepest = std::max(deepest, depth(x, g.time(), &deepest_pinned));
    ASSERT_TRUE(std::all_of(x.begin(), x.end(), [](const Vec3& p) { return p.allFinite(); })) << t;
    for (int i = 0; i < g.num_vertices(); ++i) {
      const double d = (x[i] - g.targets()[i]).norm();
      worst_over = std::max(worst_over, d - c.settings.constraints.max_distance[i]);
      if (i < columns) top_error = std::max(top_error, d);
      if (i >= (rows - 1) * columns) hem_motion = std::max(hem_motion, d);
      worst_behind = std::max(worst_behind,
                              g.constraints().backstop_depth(i, x[i], g.targets()[i], g.target_normals()[i]));
    }
  }
  std::printf(
      "body cape (%d x %d nodes): worst over max distance %.3g m, behind backstop %.3g m, top row %.3g m, "
      "hem %.3f m; deepest free vertex in a body capsule %.4f m (%.4f m at the start), top row %.4f m\n",
      columns, rows, worst_over, worst_behind, top_error, hem_motion, deepest, deepest_at_start,
      deepest_pinned);
  std::printf("the same cape without colliders: worst over max distance %.3g m, behind backstop %.3g m\n",
              bare_over, bare_behind);
  // Without colliders the constraints hold exactly. With them the contact runs last and wins where the two
  // disagree: a capsule may push a vertex past its max distance by less than the contact thickness, never
  // behind the backstop (which lies outside the body).
  EXPECT_LE(bare_over, 1e-12);
  EXPECT_LE(bare_behind, 1e-12);
  EXPECT_LE(deepest, kCapeThickness);
  EXPECT_LE(deepest_pinned, kCapeThickness);
  EXPECT_LE(worst_over, kCapeThickness);
  EXPECT_LE(worst_behind, 1e-12);
  EXPECT_LE(top_error, 1e-9);   // the shoulders' row is skinned
  EXPECT_GT(hem_motion, 0.02);  // the hem is free
  // Multiplier 0: the whole cape is the skinned mesh.
  g.set_max_distance_multiplier(0.0);
  for (int k = 181; k <= 200; ++k) {
    g.set_pose(bones_at(f, k / 60.0));
    g.step(1.0 / 60.0);
  }
  for (int i = 0; i < g.num_vertices(); ++i) EXPECT_LE((g.positions()[i] - g.targets()[i]).norm(), 1e-9);
}

TEST(BodyFit, RejectsBadInputNamingTheField) {
  const Motion m = Motion::load(loom::test::mocap("01_01.bvh"));
  SkinnedMesh empty;
  empty.source = "empty.obj";
  expect_error([&] { fit_body(empty, m); }, "empty.obj: positions", "no vertices");
  SkinnedMesh tube;
  tube.source = "tube.obj";
  add_tube(Vec3(0, 0, 0), Vec3(0, 1.7, 0), 0.2, 16, 17, tube.positions, tube.triangles);
  // A single column: no legs apart.
  expect_error([&] { fit_body(tube, m); }, "tube.obj: left_leg", "no separate section of the leg");
  tube.positions[3].y() = NAN;
  expect_error([&] { fit_body(tube, m); }, "tube.obj: positions[3]", "not finite");
  // A skeleton without legs.
  const auto bvh = loom::test::test_dir() / "spine.bvh";
  std::ofstream(bvh) << "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition "
                        "Zrotation Xrotation Yrotation\n JOINT Spine\n {\n  OFFSET 0 10 0\n  CHANNELS 3 "
                        "Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 10 0\n  }\n }\n}\n"
                        "MOTION\nFrames: 1\nFrame Time: 0.01\n0 0 0 0 0 0 0 0 0\n";
  const Motion spine = Motion::load(bvh.string());
  expect_error([&] { fit_body(load_static_mesh(body_path(), 0), spine); }, "joints", "no joint 'LeftUpLeg'");
  // The body turned to face -z.
  Affine turn = Affine::Identity();
  turn.rotate(Eigen::AngleAxisd(M_PI, Vec3::UnitY()));
  expect_error([&] { fit_body(load_static_mesh(body_path(), 0, 1.0, turn), m); }, "left_leg",
               "the mesh must face +z");
  // The cape's arguments.
  const Fitted& f = fitted();
  expect_error([&] { make_back_cape(f.fit, f.motion, 0.0); }, "cape: width", "not in (0, 100] m");
  expect_error([&] { make_back_cape(f.fit, f.motion, 0.5, NAN); }, "cape: spacing", "not in (0, 100] m");
  expect_error([&] { make_back_cape(f.fit, f.motion, 0.5, 0.05, -0.01); }, "cape: gap", "not in (0, 100] m");
  expect_error([&] { make_back_cape(f.fit, f.motion, 0.5, 0.05, 0.03, NAN); }, "cape: hem_max_distance",
               ">= 0 m");
  expect_error([&] { make_back_cape(f.fit, spine); }, "cape: motion",
               "not the motion the body was fitted to");
}

TEST(BodyFit, FitsABiovisionSkeleton) {
  // Boxing_Toes.bvh: Biovision names (LeftHip, LeftKnee, LeftCollar, LeftShoulder = upper arm, ...), no
  // pelvis-side joints, centimetres.
  const Motion m = Motion::load(loom::test::mocap("Boxing_Toes.bvh"));
  const BodyFit fit = fit_body(load_static_mesh(body_path(), 0), m);
  const std::vector<std::string> canon = canonical_joint_names(m);
  auto at = [&](const std::string& n) {
    const auto it = std::find(canon.begin(), canon.end(), n);
    EXPECT_NE(it, canon.end()) << n;
    return Vec3(fit.bind[it - canon.begin()].translation());
  };
  for (const char* side : {"Left", "Right"}) {
    const std::string s = side;
    for (const auto& [a, j, c] : std::vector<std::array<std::string, 3>>{
             {s + "UpLeg", s + "Leg", s + "Foot"}, {s + "Arm", s + "ForeArm", s + "Hand"}}) {
      const Vec3 n = (at(j) - at(a)).normalized() + (at(c) - at(j)).normalized();
      const double d =
          (nearest_loop(fit.body.positions, fit.body.triangles, at(j), n).centroid - at(j)).norm();
      std::printf("Boxing_Toes %-12s %.4f m\n", j.c_str(), d);
      EXPECT_LT(d, 0.01) << j;
    }
  }
  const Vec3s x = [&] {
    std::vector<Transform> g;
    m.pose(2.0, g);
    std::vector<Affine> pose, mats;
    pose_from_motion(match_bones(fit.body.skin, m), g, pose);
    fit.body.skin.skinning_matrices(pose, mats);
    Vec3s out;
    fit.body.skin.apply(mats, fit.body.positions, out);
    return out;
  }();
  EXPECT_TRUE(std::all_of(x.begin(), x.end(), [](const Vec3& p) { return p.allFinite(); }));
}
