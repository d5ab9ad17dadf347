// Ray casts against cloth triangles (RayCast.h), judged by exact predicates: a ray that hits a triangle
// in double crosses it exactly (orient3d signs), a ray that exactly crosses some triangle is reported hit,
// and the reported hit is the nearest crossing (brute force over all triangles).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "loom/cloth/ClothMesh.h"
#include "loom/collision/ExactPredicates.h"
#include "loom/collision/RayCast.h"

namespace lc = loom::collision;
using lc::Vec3;
using loom::cloth::ClothMesh;
using loom::cloth::GridSpec;
using loom::cloth::Tri;
using loom::cloth::Vec3s;

namespace {

// Segment p-q crosses closed triangle abc: the endpoints are on opposite (or touching) sides of its plane
// and the segment's line passes through the triangle (the three edge orientations agree). Exact; the
// `strict` version asks for strictly nonzero signs everywhere (robust crossing, no touching).
int crossing(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  const int sp = lc::orient3d(a, b, c, p), sq = lc::orient3d(a, b, c, q);
  if (sp * sq > 0 || (sp == 0 && sq == 0)) return 0;
  const int e0 = lc::orient3d(p, q, a, b), e1 = lc::orient3d(p, q, b, c), e2 = lc::orient3d(p, q, c, a);
  const bool pos = e0 >= 0 && e1 >= 0 && e2 >= 0, neg = e0 <= 0 && e1 <= 0 && e2 <= 0;
  if (!pos && !neg) return 0;
  const bool strict = sp != 0 && sq != 0 && e0 != 0 && e1 != 0 && e2 != 0;
  return strict ? 2 : 1;  // 2: strict crossing, 1: touching
}

// Coordinates on a 1/1024 grid, so p + d is exact and the ray (p, d) contains the segment p..p+d exactly.
double dyadic(std::mt19937& rng, double lo, double hi) {
  std::uniform_real_distribution<double> u(lo, hi);
  return std::round(u(rng) * 1024.0) / 1024.0;
}

}  // namespace

TEST(RayCast, TriangleHitPointAndBarycentricsAgree) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  const Vec3 o(0.25, 0.5, 2.0), d(0, 0, -1);
  const auto h = lc::ray_triangle(o, d, a, b, c);
  ASSERT_TRUE(h);
  EXPECT_DOUBLE_EQ(h->distance, 2.0);
  EXPECT_NEAR(h->barycentric.sum(), 1.0, 1e-15);
  const Vec3 on = h->barycentric[0] * a + h->barycentric[1] * b + h->barycentric[2] * c;
  EXPECT_NEAR((on - (o + h->distance * d)).norm(), 0.0, 1e-15);
  // Two-sided: from below as well; behind the origin, beyond max_distance or parallel: no hit.
  EXPECT_TRUE(lc::ray_triangle(Vec3(0.25, 0.5, -1.0), Vec3(0, 0, 1), a, b, c));
  EXPECT_FALSE(lc::ray_triangle(o, -d, a, b, c));
  EXPECT_FALSE(lc::ray_triangle(o, d, a, b, c, 1.9));
  EXPECT_FALSE(lc::ray_triangle(Vec3(0.25, 0.5, 0.0), Vec3(1, 0, 0), a, b, c));
  EXPECT_FALSE(lc::ray_triangle(o, d, a, b, a));                      // degenerate
  EXPECT_FALSE(lc::ray_triangle(Vec3(0.75, 0.75, 2.0), d, a, b, c));  // outside the hypotenuse
}

TEST(RayCast, NearestHitOnACrumpledSheetMatchesExactBruteForce) {
  GridSpec g;
  g.nodes_u = g.nodes_v = 13;
  g.origin = Vec3(-0.5, 0.0, -0.5);
  const auto mesh = ClothMesh::grid(g);
  const std::vector<Tri>& tris = mesh->triangles();
  std::mt19937 rng(7);
  Vec3s x = mesh->rest_positions();
  std::uniform_real_distribution<double> bump(-0.15, 0.15);
  for (Vec3& p : x)
    p += Vec3(0.3 * bump(rng), bump(rng), 0.3 * bump(rng));  // folds: rays cross it several times
  int hits = 0, misses = 0, multi = 0;
  for (int r = 0; r < 3000; ++r) {
    const Vec3 p(dyadic(rng, -0.8, 0.8), dyadic(rng, 0.3, 1.0) * (r % 2 ? 1 : -1), dyadic(rng, -0.8, 0.8));
    const Vec3 d(dyadic(rng, -0.8, 0.8), -p.y() * dyadic(rng, 1.5, 3.0),
                 dyadic(rng, -0.8, 0.8));  // towards/through y = 0
    const Vec3 q = p + d;                  // exact
    // Brute force: every triangle the segment crosses exactly, and the crossing's parameter along d.
    int strict = 0, touching = 0;
    double nearest_strict = 1e300;
    for (const Tri& t : tris) {
      const int c = crossing(p, q, x[t[0]], x[t[1]], x[t[2]]);
      if (c == 0) continue;
      (c == 2 ? strict : touching)++;
      if (c == 2) {
        const Vec3 n = (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);
        nearest_strict = std::min(nearest_strict, n.dot(x[t[0]] - p) / n.dot(d));  // in units of |d|
      }
    }
    multi += strict > 1;
    const auto hit = lc::ray_cast(p, d, x, tris, d.norm());
    if (strict > 0) {
      ASSERT_TRUE(hit) << "ray " << r << " crosses " << strict
                       << " triangles exactly but was reported missing";
      EXPECT_LE(hit->distance, nearest_strict * d.norm() + 1e-12)
          << "ray " << r << ": not the nearest crossing";
    }
    if (!hit) {
      ++misses;
      continue;
    }
    ++hits;
    const Tri& t = tris[hit->triangle];
    EXPECT_NE(crossing(p, q, x[t[0]], x[t[1]], x[t[2]]), 0)
        << "ray " << r << ": reported triangle not crossed exactly";
    const Vec3 on =
        hit->barycentric[0] * x[t[0]] + hit->barycentric[1] * x[t[1]] + hit->barycentric[2] * x[t[2]];
    EXPECT_LT((on - (p + hit->distance * d.normalized())).norm(), 1e-12);
    EXPECT_GE(hit->barycentric.minCoeff(), 0.0);
    EXPECT_NEAR(hit->barycentric.sum(), 1.0, 1e-14);
  }
  // The sample exercises hits, misses and rays crossing several folds.
  EXPECT_GT(hits, 300);
  EXPECT_GT(misses, 300);
  EXPECT_GT(multi, 50);
  EXPECT_EQ(lc::nearest_corner(lc::RayHit{0, Vec3(0.1, 0.7, 0.2), 1.0}, tris), tris[0][1]);
}
