// Exact intersection census over non-adjacent triangle pairs (IntersectionCensus.h).
#include "loom/collision/IntersectionCensus.h"

#include <memory>
#include <string>

#include "CensusWalk.h"
#include "loom/collision/ClothBvh.h"
#include "loom/collision/ExactPredicates.h"

namespace loom::collision {

CensusBoundExceeded::CensusBoundExceeded(int a, int b, long n)
    : std::runtime_error("the census meets more than " + std::to_string(n) +
                         " candidate triangle pairs (triangles piled onto each other)"),
      cloth_a(a),
      cloth_b(b),
      bound(n) {}

long census_walk(int tasks, const std::function<bool(int, const std::function<bool(int, int)>&)>& walk,
                 const std::function<bool(int, int)>& intersect, int threads,
                 const volatile std::sig_atomic_t* stop, long& budget) {
  // Candidates are counted per thread and published every kChunk to one shared total; a walk ends once the
  // total passes the budget or a stop is requested. Whether the budget is passed depends only on the total
  // number of candidates, so the outcome is the same for every thread count.
  constexpr long kChunk = 4096;
  std::atomic<long> seen{0};
  std::atomic<bool> over{false};
  const long limit = budget;
  long count = 0;
#pragma omp parallel for num_threads(threads) if (threads > 1) reduction(+ : count) schedule(dynamic, 1)
  for (int k = 0; k < tasks; ++k) {
    if (over || (stop && *stop)) continue;
    long local = 0;
    walk(k, [&](int i, int j) {
      if (++local == kChunk) {
        local = 0;
        if (seen.fetch_add(kChunk) + kChunk > limit) over = true;
        if (over || (stop && *stop)) return false;
      }
      count += intersect(i, j);
      return true;
    });
    seen += local;
  }
  if (stop && *stop) return -1;
  if (over || seen > limit) return -2;
  budget -= seen;
  return count;
}

long count_intersecting_pairs(const loom::cloth::ClothMesh& mesh, const loom::cloth::Vec3s& x, int threads,
                              const volatile std::sig_atomic_t* stop, long bound) {
  // A non-owning shared_ptr: the tree lives only inside this call.
  ClothBvh bvh(std::shared_ptr<const loom::cloth::ClothMesh>(&mesh, [](const loom::cloth::ClothMesh*) {}));
  bvh.rebuild(x, x, 0.0, threads);
  const long n = count_self_intersections(bvh, mesh, x, threads, stop, bound);
  if (n == -2) throw CensusBoundExceeded(-1, -1, bound);
  return n;
}

long count_self_intersections(const ClothBvh& bvh, const loom::cloth::ClothMesh& mesh,
                              const loom::cloth::Vec3s& x, int threads,
                              const volatile std::sig_atomic_t* stop, long& budget) {
  const std::vector<std::pair<int, int>> tasks = bvh.self_pair_tasks(x, x, -1.0);
  const auto& t = mesh.triangles();
  return census_walk(
      static_cast<int>(tasks.size()),
      [&](int k, const std::function<bool(int, int)>& visit) {
        return bvh.walk_self_task(tasks[k], /*skip_adjacent=*/true, visit);
      },
      [&](int i, int j) {
        const auto& a = t[i];
        const auto& b = t[j];
        return triangles_intersect(x[a[0]], x[a[1]], x[a[2]], x[b[0]], x[b[1]], x[b[2]]);
      },
      threads, stop, budget);
}

}  // namespace loom::collision
