// ClothBvh: over random deformations, candidate pairs after refit = after rebuild = brute force; box queries;
// identical results for 1 and 2 threads; the quality and step-count rebuild triggers; normal-cone culling
// never drops a pair that touches during the step, and does cull flat patches.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <random>

#include "loom/collision/Ccd.h"
#include "loom/collision/ClothBvh.h"
#include "loom/collision/ExactPredicates.h"

namespace lc = loom::collision;
using lc::Vec3;
using lc::Vec3s;
using loom::cloth::ClothMesh;
using loom::cloth::GridSpec;

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
    p = Vec3(r * std::cos(a * 3.0 + phase), amp * std::sin(5.0 * p.z()) + r * std::sin(a * 3.0 + phase),
             p.z());
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

// The census's walks (no pairs stored) visit exactly the pairs self_pairs and cross_pairs return, task by
// task, and a visit returning false ends the walk at once.
TEST(ClothBvh, WalksVisitTheSamePairsAsTheStoredLists) {
  const auto mesh = sheet(17);
  std::mt19937_64 rng(7);
  for (int it = 0; it < 4; ++it) {
    const Vec3s xa = deform(*mesh, rng, 0.004 * it), xb = deform(*mesh, rng, 0.004 * it);
    lc::ClothBvh a(mesh), b(mesh);
    a.rebuild(xa, xa, 0.001);
    b.rebuild(xb, xb, 0.001);
    for (bool skip : {false, true}) {
      std::vector<lc::TrianglePair> walked;
      for (const auto& task : a.self_pair_tasks(xa, xa, -1.0))
        EXPECT_TRUE(a.walk_self_task(task, skip, [&](int i, int j) {
          walked.emplace_back(i, j);
          return true;
        }));
      std::sort(walked.begin(), walked.end());
      EXPECT_EQ(walked, a.self_pairs(skip)) << it << " " << skip;
    }
    std::vector<lc::TrianglePair> crossed;
    const auto tasks = a.cross_pair_tasks(b);
    for (const auto& task : tasks)
      a.walk_cross_task(b, task, [&](int i, int j) {
        crossed.emplace_back(i, j);
        return true;
      });
    std::sort(crossed.begin(), crossed.end());
    const auto expect = a.cross_pairs(b);
    EXPECT_EQ(crossed, expect) << it;
    ASSERT_GT(expect.size(), 100u);
    EXPECT_GT(tasks.size(), 8u);  // split for threads
    int visits = 0;
    bool ended = true;
    for (const auto& task : tasks) {
      ended = a.walk_cross_task(b, task, [&](int, int) { return ++visits < 3; });
      if (!ended) break;
    }
    EXPECT_FALSE(ended);
    EXPECT_EQ(visits, 3);
  }
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

namespace {

// Every pair of non-adjacent triangles that brute force finds but self_pairs_culled() left out must stay
// apart over the whole step: no exact intersection at 9 times, and no vertex-face or edge-edge continuous
// contact (conservative CCD: a miss there is proof). Returns the number of pairs left out.
long check_culling_sound(const ClothMesh& mesh, const lc::ClothBvh& bvh, const Vec3s& x0, const Vec3s& x1,
                         double margin, long* culled_nodes) {
  const auto brute = lc::brute_force_pairs(mesh, x0, x1, 0.0, true);
  const auto kept = bvh.self_pairs_culled(x0, x1, margin, true, 2, culled_nodes);
  EXPECT_TRUE(std::includes(brute.begin(), brute.end(), kept.begin(), kept.end()));
  EXPECT_EQ(kept, bvh.self_pairs_culled(x0, x1, margin, true, 1));  // thread count does not matter
  std::vector<lc::TrianglePair> dropped;
  std::set_difference(brute.begin(), brute.end(), kept.begin(), kept.end(), std::back_inserter(dropped));
  const auto& tris = mesh.triangles();
  for (const auto& [i, j] : dropped) {
    const auto& a = tris[i];
    const auto& b = tris[j];
    for (int k = 0; k <= 8; ++k) {
      const double t = k / 8.0;
      auto at = [&](int v) { return Vec3((1 - t) * x0[v] + t * x1[v]); };
      EXPECT_FALSE(lc::triangles_intersect(at(a[0]), at(a[1]), at(a[2]), at(b[0]), at(b[1]), at(b[2])))
          << "culled pair " << i << " " << j << " intersects at t = " << t;
    }
    for (int side = 0; side < 2; ++side) {
      const auto& p = side ? b : a;
      const auto& f = side ? a : b;
      for (int k = 0; k < 3; ++k) {
        const int v = p[k];
        EXPECT_FALSE(
            lc::vertex_face_ccd(x0[v], x0[f[0]], x0[f[1]], x0[f[2]], x1[v], x1[f[0]], x1[f[1]], x1[f[2]]).hit)
            << "culled pair " << i << " " << j;
      }
    }
    for (int k = 0; k < 3; ++k)
      for (int m = 0; m < 3; ++m) {
        const int a0 = a[k], a1 = a[(k + 1) % 3], b0 = b[m], b1 = b[(m + 1) % 3];
        EXPECT_FALSE(lc::edge_edge_ccd(x0[a0], x0[a1], x0[b0], x0[b1], x1[a0], x1[a1], x1[b0], x1[b1]).hit)
            << "culled pair " << i << " " << j;
      }
  }
  return static_cast<long>(dropped.size());
}

// A gently waving sheet over one step (start x0, end x1): heights within 5 cm, normals within 45 degrees of
// the vertical.
void gently_waving(const ClothMesh& mesh, Vec3s& x0, Vec3s& x1) {
  x0 = mesh.rest_positions();
  x1 = x0;
  for (size_t i = 0; i < x0.size(); ++i) {
    x0[i].y() += 0.05 * std::sin(4.0 * x0[i].x()) * std::cos(3.0 * x0[i].z());
    x1[i].y() += 0.05 * std::sin(4.0 * x1[i].x() + 0.3) * std::cos(3.0 * x1[i].z());
  }
}

}  // namespace

// A gently waving sheet (normals within 45 degrees of the vertical over the step): the whole sheet is one
// height field with a simple contour, so the root is culled and no self pair is left.
TEST(ClothBvhNormalCones, FlatPatchIsCulledWhole) {
  const auto mesh = sheet(17);
  lc::ClothBvh bvh(mesh);
  Vec3s x0, x1;
  gently_waving(*mesh, x0, x1);
  bvh.refit(x0, x1, 0.0);
  EXPECT_LT(bvh.cone(0).second, 0.5 * M_PI);
  long culled = 0;
  EXPECT_GT(check_culling_sound(*mesh, bvh, x0, x1, 0.001, &culled), 0);
  EXPECT_EQ(culled, 1);
  EXPECT_TRUE(bvh.self_pairs_culled(x0, x1, 0.001, true, 1).empty());
}

// A margin larger than the edges (62.5 mm edges, 70 mm margin, as a fine mesh whose edges are about its
// thickness): two boundary edges one edge apart along the border are closer than the margin at rest. They
// need only stay apart, so the gently waving sheet is still culled whole; on crumpled and rolled sheets
// whatever is culled with that margin is still provably apart over the step.
TEST(ClothBvhNormalCones, ContourEdgesCloseAtRestNeedOnlyStayApart) {
  const auto mesh = sheet(17);
  lc::ClothBvh bvh(mesh);
  Vec3s x0, x1;
  gently_waving(*mesh, x0, x1);
  bvh.refit(x0, x1, 0.0);
  const double margin = 0.07;
  long culled = 0;
  EXPECT_GT(check_culling_sound(*mesh, bvh, x0, x1, margin, &culled), 0);
  EXPECT_EQ(culled, 1);
  std::mt19937_64 rng(5);
  long culled_total = 0;
  for (int it = 0; it < 5; ++it) {
    x0 = deform(*mesh, rng, 0.001 * it);
    x1 = x0;
    for (Vec3& p : x1) p += 0.004 * Vec3(std::sin(7.0 * p.z() + it), 0.3, std::cos(5.0 * p.x()));
    bvh.refit(x0, x1, 0.0);
    check_culling_sound(*mesh, bvh, x0, x1, margin, &culled);
    culled_total += culled;
  }
  EXPECT_GT(culled_total, 0);
}

// Rolled and folded sheets, and a fold whose upper half is thrown through the lower half during the step:
// whatever is culled is provably apart over the step, the pairs that do touch are all kept, and culling
// removes a substantial share of the pairs.
TEST(ClothBvhNormalCones, CullingNeverDropsATouchingPair) {
  const auto mesh = sheet(17);
  lc::ClothBvh bvh(mesh);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  long dropped = 0, culled_total = 0;
  for (int it = 0; it < 10; ++it) {
    Vec3s x0, x1;
    if (it < 5) {
      x0 = deform(*mesh, rng, 0.001 * it);
      x1 = x0;
      for (Vec3& p : x1) p += 0.004 * Vec3(u(rng), u(rng), u(rng));
    } else {
      // Fold at x = 0.5 (the rest sheet spans x in [0, 1]): the part beyond lies 3 mm above, turned back.
      x0 = mesh->rest_positions();
      const double gap = 0.003;
      for (Vec3& p : x0)
        if (p.x() > 0.5) p = Vec3(1.0 - p.x(), gap, p.z());
      x1 = x0;
      // The upper half falls by 2 x gap (through the lower one), with some noise.
      for (Vec3& p : x1)
        if (p.y() > 0.0) p += Vec3(0.001 * u(rng), -2.0 * gap * (it - 4) / 5.0, 0.001 * u(rng));
    }
    bvh.refit(x0, x1, 0.0);
    long culled = 0;
    dropped += check_culling_sound(*mesh, bvh, x0, x1, 0.001, &culled);
    culled_total += culled;
  }
  EXPECT_GT(culled_total, 10);
  EXPECT_GT(dropped, 1000);
}

// sort_pairs (the counting sort of candidate pairs) orders like std::sort, duplicates and empty runs
// included.
TEST(ClothBvh, SortPairsMatchesStdSort) {
  std::mt19937 rng(3);
  for (const int count : {0, 5, 63, 64, 1000, 20000}) {
    std::uniform_int_distribution<int> first(0, std::max(1, count / 7)), second(0, 3 * count + 1);
    std::vector<lc::TrianglePair> pairs(count);
    for (auto& p : pairs) p = {first(rng), second(rng)};
    auto expect = pairs;
    std::sort(expect.begin(), expect.end());
    lc::sort_pairs(pairs);
    EXPECT_EQ(pairs, expect) << count;
  }
}
