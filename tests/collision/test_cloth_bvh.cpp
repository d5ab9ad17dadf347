// ClothBvh: over random deformations, candidate pairs after refit = after rebuild = brute force; box queries;
// identical results for 1 and 2 threads; the quality and step-count rebuild triggers.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "loom/collision/ClothBvh.h"

namespace lc = loom::collision;
using loom::cloth::ClothMesh;
using loom::cloth::GridSpec;
using lc::Vec3;
using lc::Vec3s;

namespace {

std::shared_ptr<const ClothMesh> sheet(int nodes) {
  GridSpec g;
  g.size_u = g.size_v = 1.0;
  g.nodes_u = g.nodes_v = nodes;
  return ClothMesh::grid(g);
}

// A folding, crumpling deformation of the rest sheet (xz plane), plus per-vertex noise of `noise` m.
Vec3s deform(const ClothMesh& mesh, std::mt19937_64& rng, double noise) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double fold = 1.5 + u(rng), amp = 0.2 * (1.0 + u(rng)), phase = 3.0 * u(rng);
  Vec3s x = mesh.rest_positions();
  for (Vec3& p : x) {
    const double a = fold * (p.x() + 0.5);  // rolls the sheet around the z axis: layers overlap
    const double r = 0.15 + 0.05 * a;
    p = Vec3(r * std::cos(a * 3.0 + phase), amp * std::sin(5.0 * p.z()) + r * std::sin(a * 3.0 + phase), p.z());
    p += noise * Vec3(u(rng), u(rng), u(rng));
  }
  return x;
}

}  // namespace

TEST(ClothBvh, RefitEqualsRebuildEqualsBruteForce) {
  const auto mesh = sheet(17);  // 512 triangles
  lc::ClothBvh refitted(mesh);
  std::mt19937_64 rng(3);
  long non_adjacent_total = 0;
  for (int it = 0; it < 12; ++it) {
    const Vec3s x0 = deform(*mesh, rng, 0.002 * it);
    Vec3s x1 = x0;
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (Vec3& p : x1) p += 0.01 * Vec3(u(rng), u(rng), u(rng));
    const double h = 0.002 * (it % 3);
    refitted.refit(x0, x1, h);
    lc::ClothBvh rebuilt(mesh);
    rebuilt.rebuild(x0, x1, h);
    for (bool skip : {false, true}) {
      const auto brute = lc::brute_force_pairs(*mesh, x0, x1, h, skip);
      EXPECT_EQ(refitted.self_pairs(skip), brute) << "iteration " << it << " skip_adjacent " << skip;
      EXPECT_EQ(rebuilt.self_pairs(skip), brute) << "iteration " << it << " skip_adjacent " << skip;
      if (skip) non_adjacent_total += static_cast<long>(brute.size());
    }
    // Box queries against brute force.
    lc::Aabb box;
    box.grow(x0[it * 7 % x0.size()]);
    box.lo.array() -= 0.1;
    box.hi.array() += 0.1;
    std::vector<int> expect;
    for (int t = 0; t < mesh->num_triangles(); ++t) {
      lc::Aabb b;
      for (int k = 0; k < 3; ++k) b.grow(x0[mesh->triangles()[t][k]]), b.grow(x1[mesh->triangles()[t][k]]);
      b.lo.array() -= h;
      b.hi.array() += h;
      if (b.overlaps(box)) expect.push_back(t);
    }
    EXPECT_EQ(refitted.query(box), expect);
    EXPECT_EQ(rebuilt.query(box), expect);
  }
  EXPECT_GT(non_adjacent_total, 1000);  // the deformations really bring distant triangles together
}

TEST(ClothBvh, SameResultForOneAndTwoThreads) {
  const auto mesh = sheet(33);
  std::mt19937_64 rng(5);
  const Vec3s x0 = deform(*mesh, rng, 0.01), x1 = deform(*mesh, rng, 0.01);
  lc::ClothBvh a(mesh), b(mesh);
  a.refit(x0, x1, 0.001, 1);
  b.refit(x0, x1, 0.001, 2);
  EXPECT_EQ(a.surface_area_sum(), b.surface_area_sum());
  EXPECT_EQ(a.self_pairs(true), b.self_pairs(true));
}

TEST(ClothBvh, RebuildTriggers) {
  const auto mesh = sheet(17);
  lc::ClothBvhSettings s;
  s.rebuild_every = 5;
  lc::ClothBvh bvh(mesh, s);
  const Vec3s rest = mesh->rest_positions();
  // Unchanged positions: the quality does not drop, only the step count triggers.
  for (int step = 1; step <= 4; ++step) EXPECT_FALSE(bvh.update(rest, rest, 0.0)) << step;
  EXPECT_TRUE(bvh.update(rest, rest, 0.0));
  EXPECT_EQ(bvh.rebuilds(), 1);
  // Scrambled vertices: the material-space grouping no longer fits, the summed area explodes.
  std::mt19937_64 rng(9);
  Vec3s x = rest;
  std::shuffle(x.begin(), x.end(), rng);
  const double before = bvh.surface_area_sum();
  EXPECT_TRUE(bvh.update(x, x, 0.0));
  EXPECT_EQ(bvh.rebuilds(), 2);
  EXPECT_GT(bvh.surface_area_sum(), before);
  EXPECT_FALSE(bvh.update(x, x, 0.0));  // the rebuilt tree fits the scrambled state
}
