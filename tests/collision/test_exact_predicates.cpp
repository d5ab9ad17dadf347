// Exact orient3d / triangle-triangle intersection (ExactPredicates.h) and the intersection census.
#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <random>

#include "loom/collision/ClothBvh.h"
#include "loom/collision/ExactPredicates.h"
#include "loom/collision/IntersectionCensus.h"
#include "loom/collision/MultiClothCensus.h"

namespace lc = loom::collision;
using lc::Vec3;
using loom::cloth::ClothMesh;
using loom::cloth::GridSpec;
using loom::cloth::Vec3s;

TEST(ExactPredicates, Orient3dDecidesNearCoplanarPointsExactly) {
  // The plane z = (x + y) / 4 through a, b, c; d is exactly on it, d +- 2^-e z is not.
  const Vec3 a(0, 0, 0), b(4, 0, 1), c(0, 4, 1);
  const double x = 1.0 + std::ldexp(1.0, -30), y = 3.0;
  const Vec3 d(x, y, (x + y) / 4);  // 1 + 2^-32: exact
  EXPECT_EQ(lc::orient3d(a, b, c, d), 0);
  for (int e = 20; e <= 52; e += 4) {
    const Vec3 up(0, 0, std::ldexp(1.0, -e));
    const int above = lc::orient3d(a, b, c, d + up);
    EXPECT_NE(above, 0) << e;
    EXPECT_EQ(above, -lc::orient3d(a, b, c, d - up)) << e;
    EXPECT_EQ(above, lc::orient3d(a, b, c, Vec3(0, 0, 1)));  // same side as a point far above
  }
  EXPECT_EQ(lc::orient2d(Vec3(0, 0, 0), Vec3(4, 0, 1), d, 2), 1);
  EXPECT_EQ(lc::orient2d(Vec3(0, 0, 0), Vec3(2, 6, 0), Vec3(1, 3, 7), 2), 0);
}

TEST(ExactPredicates, TriangleTriangleCases) {
  const Vec3 a0(0, 0, 0), a1(4, 0, 1), a2(0, 4, 1);  // plane z = (x + y) / 4
  // A vertex exactly on the face (z = 0.5 at (1, 1)), the rest above: touching counts.
  const Vec3 on(1, 1, 0.5), up1(2, 1, 3), up2(1, 2, 3);
  EXPECT_TRUE(lc::triangles_intersect(a0, a1, a2, on, up1, up2));
  const Vec3 lifted(1, 1, std::nextafter(0.5, 1.0));
  EXPECT_FALSE(lc::triangles_intersect(a0, a1, a2, lifted, up1, up2));
  EXPECT_TRUE(
      lc::triangles_intersect(a0, a1, a2, Vec3(1, 1, std::nextafter(0.5, 0.0)), up1, up2));  // pierces
  // Piercing through the middle.
  EXPECT_TRUE(lc::triangles_intersect(a0, a1, a2, Vec3(1, 1, -1), Vec3(1.2, 1, 2), Vec3(1, 1.2, 2)));
  // Coplanar: overlapping, nested, touching at an edge point, disjoint.
  const Vec3 p0(0, 0, 0), p1(1, 0, 0), p2(0, 1, 0);
  EXPECT_TRUE(lc::triangles_intersect(p0, p1, p2, Vec3(0.5, 0.5, 0) - Vec3(0.2, 0.2, 0), Vec3(2, 0.3, 0),
                                      Vec3(0.3, 2, 0)));
  EXPECT_TRUE(lc::triangles_intersect(p0, p1, p2, Vec3(0.1, 0.1, 0), Vec3(0.2, 0.1, 0), Vec3(0.1, 0.2, 0)));
  EXPECT_TRUE(lc::triangles_intersect(p0, p1, p2, Vec3(0.5, 0.5, 0), Vec3(1, 1, 0), Vec3(2, 0.5, 0)));
  EXPECT_FALSE(lc::triangles_intersect(p0, p1, p2, Vec3(0.6, 0.6, 0), Vec3(1, 1, 0), Vec3(2, 0.5, 0)));
  // Parallel planes 2^-60 apart.
  const Vec3 dz(0, 0, std::ldexp(1.0, -60));
  EXPECT_FALSE(lc::triangles_intersect(p0, p1, p2, Vec3(0.1, 0.1, 0) + dz, Vec3(0.2, 0.1, 0) + dz,
                                       Vec3(0.1, 0.2, 0) + dz));
  // A degenerate (collinear) triangle piercing the face, and one beside it.
  EXPECT_TRUE(lc::triangles_intersect(p0, p1, p2, Vec3(0.2, 0.2, -1), Vec3(0.2, 0.2, 0), Vec3(0.2, 0.2, 1)));
  EXPECT_FALSE(lc::triangles_intersect(p0, p1, p2, Vec3(0.8, 0.8, -1), Vec3(0.8, 0.8, 0), Vec3(0.8, 0.8, 1)));
}

namespace {

std::shared_ptr<const ClothMesh> sheet(int nodes) {
  GridSpec g;
  g.nodes_u = g.nodes_v = nodes;
  g.origin = Vec3(-0.5, 0, -0.5);
  return ClothMesh::grid(g);
}

long brute_census(const ClothMesh& mesh, const Vec3s& x) {
  const auto& t = mesh.triangles();
  long n = 0;
  for (size_t i = 0; i < t.size(); ++i)
    for (size_t j = i + 1; j < t.size(); ++j) {
      bool shared = false;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) shared = shared || t[i][a] == t[j][b];
      if (!shared)
        n += lc::triangles_intersect(x[t[i][0]], x[t[i][1]], x[t[i][2]], x[t[j][0]], x[t[j][1]], x[t[j][2]]);
    }
  return n;
}

}  // namespace

TEST(IntersectionCensus, FlatSheetHasNoneAndAFoldThroughItselfHasSome) {
  const auto mesh = sheet(17);
  EXPECT_EQ(lc::count_intersecting_pairs(*mesh, mesh->rest_positions()), 0);
  // Fold the x > 0 half back over the other half, twisted so it passes through it along z = 0.
  Vec3s x = mesh->rest_positions();
  for (Vec3& p : x)
    if (p.x() > 0) p = Vec3(-p.x(), 0.6 * p.x() * p.z(), p.z());
  const long census = lc::count_intersecting_pairs(*mesh, x);
  EXPECT_GT(census, 0);
  EXPECT_EQ(census, brute_census(*mesh, x));
  EXPECT_EQ(lc::count_intersecting_pairs(*mesh, x, 2), census);
  // Random crumpling: the census equals brute force over all non-adjacent pairs.
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int it = 0; it < 3; ++it) {
    Vec3s y = mesh->rest_positions();
    for (Vec3& p : y) p = 0.3 * p + 0.03 * Vec3(u(rng), u(rng), u(rng));
    EXPECT_EQ(lc::count_intersecting_pairs(*mesh, y), brute_census(*mesh, y)) << it;
  }
}

// A cloth crushed into a 2 mm ball: every leaf box overlaps every other, so the candidates are quadratic in
// the triangles. The census walks them without storing them, and past its candidate bound it throws instead
// of running on; the bound is exact (the candidates of brute force) and the same for every thread count.
TEST(IntersectionCensus, APilePastTheCandidateBoundThrowsAtTheSameCountForEveryThreadCount) {
  const auto mesh = sheet(17);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vec3s pile = mesh->rest_positions();
  for (Vec3& p : pile) p = 0.001 * Vec3(u(rng), u(rng), u(rng));
  const long candidates = static_cast<long>(lc::brute_force_pairs(*mesh, pile, pile, 0.0, true).size());
  ASSERT_GT(candidates, 90000);  // 512 triangles: most of their 130 816 pairs
  const long census = brute_census(*mesh, pile);
  for (int threads : {1, 2}) {
    EXPECT_EQ(lc::count_intersecting_pairs(*mesh, pile, threads, nullptr, candidates), census) << threads;
    EXPECT_THROW(lc::count_intersecting_pairs(*mesh, pile, threads, nullptr, candidates - 1),
                 lc::CensusBoundExceeded)
        << threads;
    EXPECT_THROW(lc::count_intersecting_pairs(*mesh, pile, threads, nullptr, 1000), lc::CensusBoundExceeded);
  }
  // Over several cloths the bound holds for the whole call and the exception names the cloth walked.
  const Vec3s flat = mesh->rest_positions();
  std::vector<lc::CensusInput> in{{mesh.get(), &flat}, {mesh.get(), &pile}};
  try {
    lc::count_all_intersections(in, 2, nullptr, candidates - 1);
    ADD_FAILURE() << "no CensusBoundExceeded";
  } catch (const lc::CensusBoundExceeded& e) {
    EXPECT_EQ(e.cloth_a, 1);
    EXPECT_EQ(e.cloth_b, 1);
    EXPECT_EQ(e.bound, candidates - 1);
  }
  // A stop request ends the walk: -1, no count and no exception.
  volatile std::sig_atomic_t stop = 1;
  EXPECT_EQ(lc::count_intersecting_pairs(*mesh, pile, 1, &stop, 1000), -1);
  EXPECT_EQ(lc::count_all_intersections(in, 1, &stop), -1);
}

// piled_cloths: a sheet at rest, or folded through itself, has few overlapping pairs per triangle; the
// same sheet crushed into a ball, or two sheets crushed into one, pass the bound (max(1e6, 64 per triangle)).
TEST(IntersectionCensus, PiledClothsAreFoundWithinAClothAndBetweenTwo) {
  const auto mesh = sheet(129);  // 32 768 triangles: bound 2.1e6 within it, 4.2e6 between two
  Vec3s folded = mesh->rest_positions();
  for (Vec3& p : folded)
    if (p.x() > 0) p = Vec3(-p.x(), 0.6 * p.x() * p.z(), p.z());
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vec3s ball = mesh->rest_positions();
  for (Vec3& p : ball) p = 0.002 * Vec3(u(rng), u(rng), u(rng));
  const Vec3s rest = mesh->rest_positions();
  using In = std::vector<lc::CensusInput>;
  EXPECT_FALSE(lc::piled_cloths(In{{mesh.get(), &rest}}, true));
  EXPECT_FALSE(lc::piled_cloths(In{{mesh.get(), &folded}}, true));
  const auto one = lc::piled_cloths(In{{mesh.get(), &rest}, {mesh.get(), &ball}}, true);
  ASSERT_TRUE(one);
  EXPECT_EQ(one->cloth_a, 1);
  EXPECT_EQ(one->cloth_b, 1);
  EXPECT_EQ(one->bound, 64L * mesh->num_triangles());
  EXPECT_EQ(one->pairs, one->bound + 1);
  // Without self-collision only the pairs between cloths count: the ball alone passes, two balls do not.
  EXPECT_FALSE(lc::piled_cloths(In{{mesh.get(), &rest}, {mesh.get(), &ball}}, false));
  const auto two = lc::piled_cloths(In{{mesh.get(), &ball}, {mesh.get(), &ball}}, false, 2);
  ASSERT_TRUE(two);
  EXPECT_EQ(two->cloth_a, 0);
  EXPECT_EQ(two->cloth_b, 1);
  EXPECT_EQ(two->bound, 2 * 64L * mesh->num_triangles());
}

// The census over many cloths tests only the pairs of cloths whose boxes overlap (a sweep), with one tree per
// cloth: its count equals the self census of each plus the census of every pair. 40 sheets in a row, every
// other one upright, each crossing its neighbours.
TEST(IntersectionCensus, ManyClothsCountAsEveryPairCounted) {
  const auto mesh = sheet(7);
  std::vector<Vec3s> x(40, mesh->rest_positions());
  for (size_t k = 0; k < x.size(); ++k)
    for (Vec3& p : x[k]) p = (k % 2 ? Vec3(p.x(), p.z(), 0.01 * k) : p) + Vec3(0.6 * k, 0.0, 0.0);
  std::vector<lc::CensusInput> in;
  for (const Vec3s& xk : x) in.push_back({mesh.get(), &xk});
  long expect = 0, crossing_pairs = 0;
  for (size_t i = 0; i < in.size(); ++i) {
    expect += lc::count_intersecting_pairs(*mesh, x[i]);
    for (size_t j = i + 1; j < in.size(); ++j) {
      const long n = lc::count_intersecting_pairs_between(in[i], in[j]);
      expect += n;
      crossing_pairs += n > 0;
    }
  }
  EXPECT_GT(crossing_pairs, 30);
  EXPECT_EQ(lc::count_all_intersections(in), expect);
  EXPECT_EQ(lc::count_all_intersections(in, 2), expect);
}
