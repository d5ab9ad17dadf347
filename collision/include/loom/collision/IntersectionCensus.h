#pragma once
// The exact intersection census: how many pairs of non-adjacent triangles (sharing no vertex)
// intersect, touching included, with exact predicates (ExactPredicates.h). Candidates come from a ClothBvh
// built on the given positions; the count is independent of the thread count.
#include <csignal>
#include <stdexcept>

#include "loom/cloth/ClothMesh.h"

namespace loom::collision {

// The most candidate pairs (overlapping leaf boxes) one census call walks: about two seconds of exact tests
// on one core. A cloth whose triangles are piled within a few millimetres (a mesh of coincident triangles, a
// cloth crushed to a point) has candidates quadratic in its triangles (a 30 000-triangle pile: 4.5e8); past
// this bound the census throws CensusBoundExceeded instead of running for minutes.
constexpr long kCensusCandidateBound = 10'000'000;

class CensusBoundExceeded : public std::runtime_error {
 public:
  // cloth_a, cloth_b: the census inputs being walked (equal: a self census; -1: the single-cloth call).
  CensusBoundExceeded(int cloth_a, int cloth_b, long bound);
  int cloth_a, cloth_b;
  long bound;
};

// `stop`: a stop request (a signal handler's flag; nullptr: none), read between candidate pairs: once it is
// non-zero the remaining pairs are skipped and the result is -1 (no count). The candidates are walked, never
// stored; more than `bound` of them throw CensusBoundExceeded (whatever the thread count).
long count_intersecting_pairs(const loom::cloth::ClothMesh& mesh, const loom::cloth::Vec3s& x,
                              int threads = 1, const volatile std::sig_atomic_t* stop = nullptr,
                              long bound = kCensusCandidateBound);

}  // namespace loom::collision
