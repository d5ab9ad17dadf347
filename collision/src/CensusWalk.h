#pragma once
// The census's shared walk (IntersectionCensus.cpp, MultiClothCensus.cpp): candidate pairs are visited, never
// stored, and bounded.
#include <atomic>
#include <csignal>
#include <functional>

#include "loom/cloth/ClothMesh.h"
#include "loom/collision/ClothBvh.h"

namespace loom::collision {

// Runs walk(k, visit) for the tasks k = 0..tasks-1 in parallel; visit(i, j) counts intersect(i, j). Returns
// the count; -1 once `stop` is set; -2 when the candidates pass `budget` (then nothing is deducted), else
// `budget` is reduced by the candidates walked.
long census_walk(int tasks, const std::function<bool(int, const std::function<bool(int, int)>&)>& walk,
                 const std::function<bool(int, int)>& intersect, int threads,
                 const volatile std::sig_atomic_t* stop, long& budget);

// The self census of one cloth within `budget` candidates (census_walk's -1 and -2); `bvh` built on x.
long count_self_intersections(const ClothBvh& bvh, const loom::cloth::ClothMesh& mesh,
                              const loom::cloth::Vec3s& x, int threads,
                              const volatile std::sig_atomic_t* stop, long& budget);

}  // namespace loom::collision
