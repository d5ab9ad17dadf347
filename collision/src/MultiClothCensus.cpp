// Exact intersection census over several cloths (MultiClothCensus.h).
#include "loom/collision/MultiClothCensus.h"

#include <algorithm>
#include <memory>
#include <tuple>

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

long count_intersecting_pairs_between(const CensusInput& a, const CensusInput& b, int threads,
                                      const volatile std::sig_atomic_t* stop) {
  ClothBvh ta(borrow(a.mesh)), tb(borrow(b.mesh));
  ta.rebuild(*a.x, *a.x, 0.0, threads);
  tb.rebuild(*b.x, *b.x, 0.0, threads);
  const std::vector<TrianglePair> pairs = ta.cross_pairs(tb);
  const auto& t0 = a.mesh->triangles();
  const auto& t1 = b.mesh->triangles();
  const loom::cloth::Vec3s& x0 = *a.x;
  const loom::cloth::Vec3s& x1 = *b.x;
  const long n = static_cast<long>(pairs.size());
  long count = 0;
#pragma omp parallel for num_threads(threads) if (threads > 1) reduction(+ : count) schedule(dynamic, 64)
  for (long i = 0; i < n; ++i) {
    if (stop && *stop) continue;
    const auto& p = t0[pairs[i].first];
    const auto& q = t1[pairs[i].second];
    count += triangles_intersect(x0[p[0]], x0[p[1]], x0[p[2]], x1[q[0]], x1[q[1]], x1[q[2]]);
  }
  return stop && *stop ? -1 : count;
}

long count_all_intersections(const std::vector<CensusInput>& cloths, int threads,
                             const volatile std::sig_atomic_t* stop) {
  long count = 0;
  for (size_t i = 0; i < cloths.size(); ++i) {
    if (stop && *stop) return -1;
    count += count_intersecting_pairs(*cloths[i].mesh, *cloths[i].x, threads, stop);
    for (size_t j = i + 1; j < cloths.size(); ++j)
      count += count_intersecting_pairs_between(cloths[i], cloths[j], threads, stop);
  }
  return stop && *stop ? -1 : count;
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

double max_penetration(const std::vector<CensusInput>& cloths, const ColliderSet& colliders) {
  double depth = 0.0;
  for (const Collider& c : colliders)
    for (const CensusInput& in : cloths)
      for (const Vec3& p : *in.x) depth = std::max(depth, -signed_distance(c, c.curr, p, nullptr));
  return depth;
}

}  // namespace loom::collision
