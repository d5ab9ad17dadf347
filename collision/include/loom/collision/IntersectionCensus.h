#pragma once
// The exact intersection census: how many pairs of non-adjacent triangles (sharing no vertex)
// intersect, touching included, with exact predicates (ExactPredicates.h). Candidates come from a ClothBvh
// built on the given positions; the count is independent of the thread count.
#include "loom/cloth/ClothMesh.h"

namespace loom::collision {

long count_intersecting_pairs(const loom::cloth::ClothMesh& mesh, const loom::cloth::Vec3s& x,
                              int threads = 1);

}  // namespace loom::collision
