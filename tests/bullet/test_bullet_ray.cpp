// BulletCloth::ray_test: picking through a draped cloth agrees with an independent brute-force
// segment-triangle test (plane intersection + inside test by signed areas) on thousands of random rays.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "BulletTestWorld.h"
#include "loom/bullet/ClothRay.h"

namespace loom::test {
namespace {

struct RefHit {
  int triangle = -1;
  double distance = HUGE_VAL;
};

// Reference: nearest crossing of the segment with each triangle's plane whose point lies inside the
// triangle (all three sub-triangle areas along the normal >= 0).
RefHit reference(const cloth::ClothMesh& mesh, const cloth::Vec3s& x, const Vec3& from, const Vec3& to) {
  RefHit best;
  const Vec3 d = to - from;
  for (int k = 0; k < mesh.num_triangles(); ++k) {
    const cloth::Tri& t = mesh.triangles()[k];
    const Vec3 &a = x[t[0]], &b = x[t[1]], &c = x[t[2]];
    const Vec3 n = (b - a).cross(c - a);
    const double den = n.dot(d);
    if (den == 0.0) continue;
    const double s = n.dot(a - from) / den;
    if (s < 0.0 || s > 1.0) continue;
    const Vec3 p = from + s * d;
    if (n.dot((b - a).cross(p - a)) < 0 || n.dot((c - b).cross(p - b)) < 0 || n.dot((a - c).cross(p - c)) < 0)
      continue;
    const double dist = s * d.norm();
    if (dist < best.distance) best = {k, dist};
  }
  return best;
}

bool share_vertex(const cloth::ClothMesh& mesh, int i, int j) {
  for (int a : mesh.triangles()[i])
    for (int b : mesh.triangles()[j])
      if (a == b) return true;
  return false;
}

TEST(BulletClothRay, MatchesBruteForceOnDrapedCloth) {
  // Drape a sheet over a sphere for 0.5 s.
  TestWorld w;
  w.add_body(new btSphereShape(0.3), 0.0, Vec3(0.0, 0.0, 0.0));
  bullet::BulletClothSettings s = setup_tier();
  s.cloth_substeps = 10;
  bullet::BulletCloth* c = w.add_cloth(sheet(25, 1.2, Vec3(-0.6, 0.35, -0.6)), s);
  for (int f = 0; f < 30; ++f) w.frame();
  const auto& mesh = c->simulation().cloths()[0]->mesh();
  const cloth::Vec3s& x = c->simulation().cloths()[0]->state().x;

  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-0.8, 0.8);
  int hits = 0, misses = 0, edge_ties = 0;
  for (int r = 0; r < 4000; ++r) {
    const Vec3 from(u(rng), 1.0 + 0.5 * std::abs(u(rng)), u(rng));
    const Vec3 to(u(rng), -0.6 - 0.5 * std::abs(u(rng)), u(rng));
    const bullet::RayHit h = c->ray_test(from, to);
    const RefHit ref = reference(mesh, x, from, to);
    ASSERT_EQ(h.hit, ref.triangle >= 0) << "ray " << r;
    if (!h.hit) {
      ++misses;
      continue;
    }
    ++hits;
    EXPECT_NEAR(h.distance, ref.distance, 1e-9 * ref.distance) << "ray " << r;
    if (h.triangle != ref.triangle) {
      // Only a ray through a shared edge or vertex may name either neighbour.
      ASSERT_TRUE(share_vertex(mesh, h.triangle, ref.triangle)) << "ray " << r;
      ++edge_ties;
    }
    // The barycentric point is the hit point.
    const cloth::Tri& t = mesh.triangles()[h.triangle];
    const Vec3 p = h.barycentric[0] * x[t[0]] + h.barycentric[1] * x[t[1]] + h.barycentric[2] * x[t[2]];
    EXPECT_LT((p - h.point).norm(), 1e-12 * (1.0 + h.distance));
    EXPECT_NEAR(h.barycentric.sum(), 1.0, 1e-12);
    EXPECT_GE(h.barycentric.minCoeff(), 0.0);
  }
  EXPECT_GT(hits, 1000);
  EXPECT_GT(misses, 100);
  EXPECT_LE(edge_ties, 4);
  std::printf("rays: %d hits, %d misses, %d edge ties\n", hits, misses, edge_ties);
}

TEST(BulletClothRay, CasterEqualsBruteForceLoop) {
  // The BVH-culled caster and the plain loop run the same exact test: identical results.
  cloth::GridSpec g;
  g.nodes_u = g.nodes_v = 20;
  auto mesh = cloth::ClothMesh::grid(g);
  cloth::Vec3s x = mesh->rest_positions();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.05, 0.05), v(-0.2, 1.2);
  for (Vec3& p : x) p += Vec3(u(rng), 3 * u(rng), u(rng));
  bullet::ClothRayCaster caster(mesh);
  for (int r = 0; r < 2000; ++r) {
    const Vec3 from(v(rng), 0.5, v(rng)), to(v(rng), -0.5, v(rng));
    const bullet::RayHit a = caster.cast(x, from, to), b = bullet::ray_triangles(*mesh, x, from, to);
    ASSERT_EQ(a.hit, b.hit);
    if (!a.hit) continue;
    EXPECT_EQ(a.triangle, b.triangle);
    EXPECT_EQ(a.distance, b.distance);
  }
}

}  // namespace
}  // namespace loom::test
