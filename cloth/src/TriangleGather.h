#pragma once
// Per-triangle forces added to vertices in a fixed order (bit-identical for any thread count).
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::cloth {

// f[i] += Σ tri_force[t] over the triangles t of vertex i (vertex_triangles[i], ascending). Holds an orphaned
// `omp for`: call it from every thread of a parallel region, or serially.
inline void gather_triangle_forces(const Vec3s& tri_force,
                                   const std::vector<std::vector<int>>& vertex_triangles, Vec3s& f) {
  const int nv = static_cast<int>(vertex_triangles.size());
#pragma omp for schedule(static)
  for (int i = 0; i < nv; ++i) {
    Vec3 acc = Vec3::Zero();
    for (int t : vertex_triangles[i]) acc += tri_force[t];
    f[i] += acc;
  }
}

}  // namespace loom::cloth
