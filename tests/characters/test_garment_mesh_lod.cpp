// GarmentMeshLod: a coarse garment simulated far away and shown through the curved-face hybrid, the fine
// mesh simulated near, switched by distance without a pop.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "TestCape.h"
#include "loom/characters/GarmentMeshLod.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Error.h"

using namespace loom::characters;
using loom::cloth::Vec3;
using loom::cloth::Vec3s;
using Iso = Eigen::Isometry3d;

namespace {

using Cape = loom::test::TestCape;

Cape make_cape() { return loom::test::make_test_cape({6, 7, -1.0, true, 0.05}); }

std::vector<Affine> pose_at(const Cape& c, double t) {
  Iso f = Iso::Identity();
  f.translate(Vec3(0.4 * std::sin(2 * M_PI * 0.5 * t), 0, 0.3 * t));
  f.rotate(Eigen::AngleAxisd(0.6 * std::sin(2 * M_PI * 0.7 * t), Vec3::UnitY()));
  return {f * c.bind_pose[0], f * c.bind_pose[1]};
}

// Largest second difference |x(f) - 2 x(f-1) + x(f-2)| of a shown vertex (m): the change of its per-frame
// motion, which a pop makes jump while the clip's own motion changes smoothly.
double max_jerk(const Vec3s& a, const Vec3s& b, const Vec3s& c) {
  double d = 0.0;
  for (size_t i = 0; i < a.size(); ++i) d = std::max(d, (a[i] - 2.0 * b[i] + c[i]).norm());
  return d;
}

struct LodRun {
  double normal = 0.0;     // m, largest second difference away from the switches
  double at_switch = 0.0;  // m, largest second difference at a switch frame or the one after
  long fine_steps_while_coarse = 0;
  bool finite = true;
};

// 3 s at 60 Hz: coarse, fine from frame 60 (distance 1 m), coarse again from frame 120 (distance 20 m).
LodRun play(double blend_time) {
  const Cape c = make_cape();
  GarmentMeshLodSettings lod;
  lod.blend_time = blend_time;
  GarmentMeshLod g(c.bind, c.tris, c.skin, c.settings, pose_at(c, 0.0), lod, "cape");
  LodRun r;
  Vec3s prev2 = g.shown(), prev = g.shown();
  for (int f = 1; f <= 180; ++f) {
    g.set_distance(f >= 60 && f < 120 ? 1.0 : 20.0);
    g.set_pose(pose_at(c, f / 60.0));
    const long fine_before = g.fine().solver_steps();
    g.step(1.0 / 60.0);
    if (!g.fine_active() && f != 120) r.fine_steps_while_coarse += g.fine().solver_steps() - fine_before;
    if (f >= 2) {
      const double jerk = max_jerk(g.shown(), prev, prev2);
      if (f == 60 || f == 61 || f == 120 || f == 121) {
        r.at_switch = std::max(r.at_switch, jerk);
      } else if (f > 10) {  // after the start-up
        r.normal = std::max(r.normal, jerk);
      }
    }
    for (const Vec3& p : g.shown()) r.finite = r.finite && p.allFinite();
    prev2 = prev;
    prev = g.shown();
  }
  EXPECT_EQ(g.switches(), 2);
  return r;
}

}  // namespace

TEST(GarmentMeshLod, SwitchesByDistanceWithoutAPop) {
  const LodRun blended = play(0.2);
  const LodRun sharp = play(0.0);
  ASSERT_TRUE(blended.finite && sharp.finite);
  std::printf("second difference: normal %.4f m, at the switch %.4f m blended, %.4f m unblended\n",
              blended.normal, blended.at_switch, sharp.at_switch);
  // The blended switch changes the shown motion no more than an ordinary frame of the clip; unblended, the
  // shown surface jumps: the blend removes at least a third of the jump.
  EXPECT_LE(blended.at_switch, blended.normal);
  EXPECT_GT(sharp.at_switch, 1.5 * blended.at_switch);
  // Far, only the coarse garment is simulated.
  EXPECT_EQ(blended.fine_steps_while_coarse, 0);
}

TEST(GarmentMeshLod, FineGarmentFollowsTheCoarseSkinAndMaps) {
  const Cape c = make_cape();
  GarmentMeshLodSettings lod;
  lod.levels = 2;
  GarmentMeshLod g(c.bind, c.tris, c.skin, c.settings, pose_at(c, 0.0), lod, "cape");
  EXPECT_EQ(g.num_vertices(), g.fine().num_vertices());
  EXPECT_EQ(g.triangles().size(), 16 * c.tris.size());
  // Fully skinned (multiplier 0), the fine simulation is the fine skinned mesh, which matches the coarse
  // skinned mesh at the coarse vertices.
  g.force(true);
  g.fine().set_max_distance_multiplier(0.0);
  for (int f = 1; f <= 30; ++f) {
    g.set_pose(pose_at(c, f / 60.0));
    g.step(1.0 / 60.0);
  }
  ASSERT_TRUE(g.fine_active());
  g.coarse().set_pose(pose_at(c, 30 / 60.0));
  for (int i = 0; i < g.coarse().num_vertices(); ++i) {
    const int f = g.curved_faces().fine_vertex_of(i);
    EXPECT_LE((g.fine().positions()[f] - g.fine().skinned()[f]).norm(), 1e-9);
    EXPECT_LE((g.fine().skinned()[f] - g.coarse().skinned()[i]).norm(), 1e-9);
  }
  // The fine max distances are the coarse ones interpolated: 0 only on the top edge, 0.3 m on the hem.
  double lo = HUGE_VAL, hi = 0.0;
  for (int f = 0; f < g.fine().num_vertices(); ++f) {
    const double d = g.fine().constraints().settings().max_distance[f];
    lo = std::min(lo, d), hi = std::max(hi, d);
  }
  EXPECT_EQ(lo, 0.0);
  EXPECT_NEAR(hi, 0.3, 1e-12);
}

TEST(GarmentMeshLod, DistanceHysteresisAndBadSettings) {
  const Cape c = make_cape();
  GarmentMeshLod g(c.bind, c.tris, c.skin, c.settings, pose_at(c, 0.0), {}, "cape");  // switch at 5 +- 0.5 m
  auto at = [&](double d) {
    g.set_distance(d);
    g.set_pose(pose_at(c, 0.0));
    g.step(1.0 / 60.0);
    return g.fine_active();
  };
  EXPECT_FALSE(at(4.8));  // inside the band: stays coarse
  EXPECT_TRUE(at(4.4));
  EXPECT_TRUE(at(5.4));  // inside the band: stays fine
  EXPECT_FALSE(at(5.6));
  auto message = [&](const GarmentMeshLodSettings& s) -> std::string {
    try {
      GarmentMeshLod bad(c.bind, c.tris, c.skin, c.settings, pose_at(c, 0.0), s, "cape");
    } catch (const loom::Error& e) {
      return e.what();
    }
    return "";
  };
  GarmentMeshLodSettings s;
  s.levels = 0;
  EXPECT_NE(message(s).find("lod_mesh.levels"), std::string::npos) << message(s);
  s = {};
  s.switch_distance = std::nan("");
  EXPECT_NE(message(s).find("lod_mesh.switch_distance"), std::string::npos) << message(s);
  s = {};
  s.hysteresis = -1;
  EXPECT_NE(message(s).find("lod_mesh.hysteresis"), std::string::npos) << message(s);
  s = {};
  s.blend_time = -1;
  EXPECT_NE(message(s).find("lod_mesh.blend_time"), std::string::npos) << message(s);
  EXPECT_THROW(g.set_distance(-1.0), loom::Error);
}
