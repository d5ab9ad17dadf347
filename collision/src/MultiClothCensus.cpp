// Exact intersection census over several cloths (MultiClothCensus.h).
#include "loom/collision/MultiClothCensus.h"

#include <algorithm>
#include <memory>
#include <tuple>

#include "CensusWalk.h"
#include "loom/collision/ClothBvh.h"
#include "loom/collision/ColliderDistance.h"
#include "loom/collision/ExactPredicates.h"
#include "loom/collision/IntersectionCensus.h"

namespace loom::collision {
namespace {

std::shared_ptr<const loom::cloth::ClothMesh> borrow(const loom::cloth::ClothMesh* m) {
  return std::shared_ptr<const loom::cloth::ClothMesh>(m, [](const loom::cloth::ClothMesh*) {});
}

}  // namespace

namespace {

long count_between(const ClothBvh& ta, const ClothBvh& tb, const CensusInput& a, const CensusInput& b,
                   int threads, const volatile std::sig_atomic_t* stop, long& budget) {
  const std::vector<std::pair<int, int>> tasks = ta.cross_pair_tasks(tb);
  const auto& t0 = a.mesh->triangles();
  const auto& t1 = b.mesh->triangles();
  const loom::cloth::Vec3s& x0 = *a.x;
  const loom::cloth::Vec3s& x1 = *b.x;
  return census_walk(
      static_cast<int>(tasks.size()),
      [&](int k, const std::function<bool(int, int)>& visit) {
        return ta.walk_cross_task(tb, tasks[k], visit);
      },
      [&](int i, int j) {
        const auto& p = t0[i];
        const auto& q = t1[j];
        return triangles_intersect(x0[p[0]], x0[p[1]], x0[p[2]], x1[q[0]], x1[q[1]], x1[q[2]]);
      },
      threads, stop, budget);
}

// One tree per cloth, built on its positions (boxes of the triangles, no thickness).
std::vector<std::unique_ptr<ClothBvh>> build_trees(const std::vector<CensusInput>& cloths, int threads) {
  std::vector<std::unique_ptr<ClothBvh>> trees;
  for (const CensusInput& c : cloths) {
    trees.push_back(std::make_unique<ClothBvh>(borrow(c.mesh)));
    trees.back()->rebuild(*c.x, *c.x, 0.0, threads);
  }
  return trees;
}

// The pairs (i < j) of cloths whose root boxes overlap, sorted: a sweep along x, so many cloths apart cost
// n log n, not a test per pair.
std::vector<std::pair<int, int>> overlapping_cloths(const std::vector<std::unique_ptr<ClothBvh>>& trees) {
  const int n = static_cast<int>(trees.size());
  std::vector<Aabb> box(n);
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) box[i] = trees[i]->root_box(), order[i] = i;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return box[a].lo.x() < box[b].lo.x(); });
  std::vector<std::pair<int, int>> out;
  for (int k = 0; k < n; ++k)
    for (int m = k + 1; m < n && box[order[m]].lo.x() <= box[order[k]].hi.x(); ++m)
      if (box[order[k]].overlaps(box[order[m]]))
        out.push_back({std::min(order[k], order[m]), std::max(order[k], order[m])});
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

long count_intersecting_pairs_between(const CensusInput& a, const CensusInput& b, int threads,
                                      const volatile std::sig_atomic_t* stop, long bound) {
  const auto trees = build_trees({a, b}, threads);
  const long n = count_between(*trees[0], *trees[1], a, b, threads, stop, bound);
  if (n == -2) throw CensusBoundExceeded(0, 1, bound);
  return n;
}

long count_all_intersections(const std::vector<CensusInput>& cloths, int threads,
                             const volatile std::sig_atomic_t* stop, long bound) {
  long count = 0, budget = bound;
  const auto trees = build_trees(cloths, threads);
  std::vector<std::pair<int, int>> pairs;  // self (i, i) first, then the overlapping cloth pairs
  for (int i = 0; i < static_cast<int>(cloths.size()); ++i) pairs.push_back({i, i});
  for (const auto& p : overlapping_cloths(trees)) pairs.push_back(p);
  for (const auto& [i, j] : pairs) {
    if (stop && *stop) return -1;
    const long n =
        i == j ? count_self_intersections(*trees[i], *cloths[i].mesh, *cloths[i].x, threads, stop, budget)
               : count_between(*trees[i], *trees[j], cloths[i], cloths[j], threads, stop, budget);
    if (n == -1) return -1;
    if (n == -2) throw CensusBoundExceeded(i, j, bound);
    count += n;
  }
  return count;
}

bool IntersectingPair::operator<(const IntersectingPair& o) const {
  return std::tie(cloth_a, tri_a, cloth_b, tri_b) < std::tie(o.cloth_a, o.tri_a, o.cloth_b, o.tri_b);
}

bool IntersectingPair::operator==(const IntersectingPair& o) const {
  return cloth_a == o.cloth_a && tri_a == o.tri_a && cloth_b == o.cloth_b && tri_b == o.tri_b;
}

std::vector<IntersectingPair> intersecting_pairs(const std::vector<CensusInput>& cloths,
                                                 const std::vector<const ClothBvh*>& trees, int threads,
                                                 double cone_margin) {
  std::vector<IntersectingPair> out;
  for (size_t i = 0; i < cloths.size(); ++i) {
    for (size_t j = i; j < cloths.size(); ++j) {
      // Candidates: overlapping leaf boxes (within one cloth, pairs sharing a vertex left out).
      const std::vector<TrianglePair> cand =
          i != j ? trees[i]->cross_pairs(*trees[j])
          : cone_margin < 0.0
              ? trees[i]->self_pairs(/*skip_adjacent=*/true)
              : trees[i]->self_pairs_culled(*cloths[i].x, *cloths[i].x, cone_margin, true, threads);
      const auto& t0 = cloths[i].mesh->triangles();
      const auto& t1 = cloths[j].mesh->triangles();
      const loom::cloth::Vec3s& x0 = *cloths[i].x;
      const loom::cloth::Vec3s& x1 = *cloths[j].x;
      const long n = static_cast<long>(cand.size());
      std::vector<char> hit(cand.size(), 0);
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(dynamic, 64)
      for (long k = 0; k < n; ++k) {
        const auto& p = t0[cand[k].first];
        const auto& q = t1[cand[k].second];
        hit[k] = triangles_intersect(x0[p[0]], x0[p[1]], x0[p[2]], x1[q[0]], x1[q[1]], x1[q[2]]);
      }
      for (long k = 0; k < n; ++k)
        if (hit[k]) out.push_back({static_cast<int>(i), cand[k].first, static_cast<int>(j), cand[k].second});
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<IntersectingPair> intersecting_pairs(const std::vector<CensusInput>& cloths, int threads) {
  std::vector<std::unique_ptr<ClothBvh>> own;
  std::vector<const ClothBvh*> trees;
  for (const CensusInput& c : cloths) {
    own.push_back(std::make_unique<ClothBvh>(borrow(c.mesh)));
    own.back()->rebuild(*c.x, *c.x, 0.0, threads);
    trees.push_back(own.back().get());
  }
  return intersecting_pairs(cloths, trees, threads);
}

std::optional<PiledCloths> piled_cloths(const std::vector<CensusInput>& cloths, bool self, int threads) {
  const auto trees = build_trees(cloths, threads);
  std::vector<std::pair<int, int>> pairs;
  if (self)
    for (int i = 0; i < static_cast<int>(cloths.size()); ++i) pairs.push_back({i, i});
  for (const auto& p : overlapping_cloths(trees)) pairs.push_back(p);
  for (const auto& [i, j] : pairs) {
    const long triangles = cloths[i].mesh->num_triangles() + (i == j ? 0 : cloths[j].mesh->num_triangles());
    PiledCloths p{i, j, 0, std::max(kPiledPairsMin, kPiledPairsPerTriangle * triangles)};
    const auto count = [&p](int, int) { return ++p.pairs <= p.bound; };
    bool within = true;
    if (i == j) {
      for (const auto& task : trees[i]->self_pair_tasks(*cloths[i].x, *cloths[i].x, -1.0))
        if (!(within = trees[i]->walk_self_task(task, /*skip_adjacent=*/true, count))) break;
    } else {
      for (const auto& task : trees[i]->cross_pair_tasks(*trees[j]))
        if (!(within = trees[i]->walk_cross_task(*trees[j], task, count))) break;
    }
    if (!within) return p;
  }
  return std::nullopt;
}

double max_penetration(const std::vector<CensusInput>& cloths, const ColliderSet& colliders) {
  double depth = 0.0;
  for (const Collider& c : colliders)
    for (const CensusInput& in : cloths)
      for (const Vec3& p : *in.x) depth = std::max(depth, -signed_distance(c, c.curr, p, nullptr));
  return depth;
}

}  // namespace loom::collision
