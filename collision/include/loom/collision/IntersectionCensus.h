#pragma once
// The exact intersection census: how many pairs of non-adjacent triangles (sharing no vertex)
// intersect, touching included, with exact predicates (ExactPredicates.h). Candidates come from a ClothBvh
// built on the given positions; the count is independent of the thread count.
#include <csignal>

#include "loom/cloth/ClothMesh.h"

namespace loom::collision {

// `stop`: a stop request (a signal handler's flag; nullptr: none), read between candidate pairs: once it is
// non-zero the remaining pairs are skipped and the result is -1 (no count).
long count_intersecting_pairs(const loom::cloth::ClothMesh& mesh, const loom::cloth::Vec3s& x,
                              int threads = 1, const volatile std::sig_atomic_t* stop = nullptr);

}  // namespace loom::collision
