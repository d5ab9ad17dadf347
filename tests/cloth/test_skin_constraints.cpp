// SkinConstraints: max distance, backstop (plane and sphere), animation drive and the global multiplier.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "loom/cloth/Error.h"
#include "loom/cloth/SkinConstraints.h"

using namespace loom::cloth;

namespace {

struct Cloud {
  Vec3s p, n, x, v;
};

// n random targets with random unit normals and positions up to 0.2 m from them.
Cloud cloud(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Cloud c;
  for (int i = 0; i < count; ++i) {
    c.p.emplace_back(u(rng), u(rng), u(rng));
    c.n.push_back(Vec3(u(rng), u(rng), u(rng)).normalized());
    c.x.push_back(c.p.back() + 0.2 * Vec3(u(rng), u(rng), u(rng)));
    c.v.emplace_back(u(rng), u(rng), u(rng));
  }
  return c;
}

std::string error_of(const SkinConstraintSettings& s, int n) {
  try {
    SkinConstraints c(s, n, "garment");
  } catch (const loom::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(SkinConstraints, ZeroMaxDistanceIsTheSkinnedMeshAndUpdatesVelocity) {
  Cloud c = cloud(200, 1);
  SkinConstraintSettings s;
  s.max_distance.assign(200, 0.0);
  SkinConstraints pass(s, 200);
  const Vec3s x0 = c.x, v0 = c.v;
  const double h = 1.0 / 240.0;
  EXPECT_EQ(pass.apply(c.p, c.n, h, c.x, c.v), 200);
  for (int i = 0; i < 200; ++i) {
    EXPECT_LE((c.x[i] - c.p[i]).norm(), 1e-9);
    EXPECT_NEAR((c.v[i] - v0[i] - (c.p[i] - x0[i]) / h).norm(), 0.0, 1e-9);
  }
}

TEST(SkinConstraints, NoVertexBeyondItsMaxDistanceNorBehindThePlaneBackstop) {
  Cloud c = cloud(5000, 2);
  SkinConstraintSettings s;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 0.15);
  for (int i = 0; i < 5000; ++i) {
    s.max_distance.push_back(u(rng));
    s.backstop_distance.push_back(0.5 * u(rng));
  }
  SkinConstraints pass(s, 5000);
  long moved = pass.apply(c.p, c.n, 0.01, c.x, c.v);
  EXPECT_GT(moved, 1000);
  for (int i = 0; i < 5000; ++i) {
    EXPECT_LE((c.x[i] - c.p[i]).norm(), s.max_distance[i] + 1e-12) << i;
    EXPECT_LE(pass.backstop_depth(i, c.x[i], c.p[i], c.n[i]), 1e-12) << i;
  }
}

TEST(SkinConstraints, SphereBackstopKeepsBothContracts) {
  Cloud c = cloud(5000, 4);
  SkinConstraintSettings s;
  s.backstop_radius = 0.3;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 0.15);
  for (int i = 0; i < 5000; ++i) {
    s.max_distance.push_back(u(rng));
    s.backstop_distance.push_back(0.3 * u(rng));
  }
  SkinConstraints pass(s, 5000);
  pass.apply(c.p, c.n, 0.01, c.x, c.v);
  int was_inside = 0;
  for (int i = 0; i < 5000; ++i) {
    EXPECT_LE((c.x[i] - c.p[i]).norm(), s.max_distance[i] + 1e-9) << i;
    EXPECT_LE(pass.backstop_depth(i, c.x[i], c.p[i], c.n[i]), 1e-9) << i;
    // Vertices on the sphere were pushed there.
    const Vec3 centre = c.p[i] - (s.backstop_distance[i] + 0.3) * c.n[i];
    was_inside += std::abs((c.x[i] - centre).norm() - 0.3) < 1e-9;
  }
  EXPECT_GT(was_inside, 100);
}

TEST(SkinConstraints, DriveDecaysTheOffsetExponentially) {
  Cloud c = cloud(50, 6);
  SkinConstraintSettings s;
  s.drive_stiffness = 20.0;  // 1/s
  SkinConstraints pass(s, 50);
  const Vec3s x0 = c.x;
  const double h = 0.01;
  pass.apply(c.p, c.n, h, c.x, c.v);
  for (int i = 0; i < 50; ++i)
    EXPECT_NEAR((c.x[i] - c.p[i]).norm(), std::exp(-20.0 * h) * (x0[i] - c.p[i]).norm(), 1e-12);
}

TEST(SkinConstraints, MultiplierBlendsSkinnedToSimulated) {
  Cloud c = cloud(100, 7);
  SkinConstraintSettings s;
  s.max_distance.assign(100, 0.05);
  s.max_distance_multiplier = 0.0;
  Cloud a = c;
  SkinConstraints pass(s, 100);
  pass.apply(a.p, a.n, 0.01, a.x, a.v);
  for (int i = 0; i < 100; ++i) EXPECT_LE((a.x[i] - a.p[i]).norm(), 1e-9);
  Cloud b = c;
  pass.set_max_distance_multiplier(std::numeric_limits<double>::infinity());
  EXPECT_EQ(pass.apply(b.p, b.n, 0.01, b.x, b.v), 0);
  Cloud d = c;
  pass.set_max_distance_multiplier(2.0);
  pass.apply(d.p, d.n, 0.01, d.x, d.v);
  for (int i = 0; i < 100; ++i) EXPECT_LE((d.x[i] - d.p[i]).norm(), 0.1 + 1e-12);
  EXPECT_THROW(pass.set_max_distance_multiplier(-1.0), loom::Error);
}

TEST(SkinConstraints, RejectsBadSettingsNamingTheField) {
  SkinConstraintSettings s;
  s.max_distance = {0.1, -0.2, 0.0};
  EXPECT_NE(error_of(s, 3).find("garment: max_distance[1]: -0.2"), std::string::npos) << error_of(s, 3);
  s.max_distance = {0.1, NAN, 0.0};
  EXPECT_NE(error_of(s, 3).find("max_distance[1]"), std::string::npos);
  s.max_distance = {0.1};
  EXPECT_NE(error_of(s, 3).find("max_distance: has 1 values for 3 vertices"), std::string::npos);
  s.max_distance.clear();
  s.backstop_distance = {0.0, 0.0, INFINITY};
  EXPECT_NE(error_of(s, 3).find("backstop_distance[2]"), std::string::npos);
  s.backstop_distance.clear();
  s.backstop_radius = -1.0;
  EXPECT_NE(error_of(s, 3).find("backstop_radius"), std::string::npos);
  s.backstop_radius = 0.0;
  s.drive_stiffness = NAN;
  EXPECT_NE(error_of(s, 3).find("drive_stiffness"), std::string::npos);
  s.drive_stiffness = 0.0;
  s.max_distance_multiplier = -0.5;
  EXPECT_NE(error_of(s, 3).find("max_distance_multiplier"), std::string::npos);
}
