// Exact intersection census over non-adjacent triangle pairs (IntersectionCensus.h).
#include "loom/collision/IntersectionCensus.h"

#include <memory>

#include "loom/collision/ClothBvh.h"
#include "loom/collision/ExactPredicates.h"

namespace loom::collision {

long count_intersecting_pairs(const loom::cloth::ClothMesh& mesh, const loom::cloth::Vec3s& x, int threads,
                              const volatile std::sig_atomic_t* stop) {
  // A non-owning shared_ptr: the tree lives only inside this call.
  ClothBvh bvh(std::shared_ptr<const loom::cloth::ClothMesh>(&mesh, [](const loom::cloth::ClothMesh*) {}));
  bvh.rebuild(x, x, 0.0, threads);
  const std::vector<TrianglePair> pairs = bvh.self_pairs(/*skip_adjacent=*/true);
  const auto& t = mesh.triangles();
  const long n = static_cast<long>(pairs.size());
  long count = 0;
#pragma omp parallel for num_threads(threads) if (threads > 1) reduction(+ : count) schedule(dynamic, 64)
  for (long i = 0; i < n; ++i) {
    if (stop && *stop) continue;
    const auto& a = t[pairs[i].first];
    const auto& b = t[pairs[i].second];
    count += triangles_intersect(x[a[0]], x[a[1]], x[a[2]], x[b[0]], x[b[1]], x[b[2]]);
  }
  return stop && *stop ? -1 : count;
}

}  // namespace loom::collision
