// Exact intersection census over several cloths (MultiClothCensus.h).
#include "loom/collision/MultiClothCensus.h"

#include <algorithm>
#include <memory>

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

long count_intersecting_pairs_between(const CensusInput& a, const CensusInput& b, int threads) {
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
    const auto& p = t0[pairs[i].first];
    const auto& q = t1[pairs[i].second];
    count += triangles_intersect(x0[p[0]], x0[p[1]], x0[p[2]], x1[q[0]], x1[q[1]], x1[q[2]]);
  }
  return count;
}

long count_all_intersections(const std::vector<CensusInput>& cloths, int threads) {
  long count = 0;
  for (size_t i = 0; i < cloths.size(); ++i) {
    count += count_intersecting_pairs(*cloths[i].mesh, *cloths[i].x, threads);
    for (size_t j = i + 1; j < cloths.size(); ++j) count += count_intersecting_pairs_between(cloths[i], cloths[j], threads);
  }
  return count;
}

double max_penetration(const std::vector<CensusInput>& cloths, const ColliderSet& colliders) {
  double depth = 0.0;
  for (const Collider& c : colliders)
    for (const CensusInput& in : cloths)
      for (const Vec3& p : *in.x) depth = std::max(depth, -signed_distance(c, c.curr, p, nullptr));
  return depth;
}

}  // namespace loom::collision
