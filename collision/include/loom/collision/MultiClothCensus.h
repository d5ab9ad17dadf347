#pragma once
// The exact intersection census over several cloths (issue 5, `loom run --census`): the self census of each
// cloth (IntersectionCensus.h: intersecting pairs of triangles sharing no vertex) plus, for every pair of
// cloths, the count of intersecting triangle pairs between them (all pairs: two cloths share no vertex).
// Exact predicates (ExactPredicates.h); the count is independent of the thread count.
#include <vector>

#include "loom/cloth/ClothMesh.h"
#include "loom/collision/Collider.h"

namespace loom::collision {

struct CensusInput {
  const loom::cloth::ClothMesh* mesh = nullptr;
  const loom::cloth::Vec3s* x = nullptr;  // m, one position per mesh vertex
};

// Intersecting triangle pairs between two different cloths.
long count_intersecting_pairs_between(const CensusInput& a, const CensusInput& b, int threads = 1);
// Self census of every cloth plus every cloth pair.
long count_all_intersections(const std::vector<CensusInput>& cloths, int threads = 1);
// Largest depth (m) of any cloth vertex inside any collider at its current pose (`curr`), by the collider's
// signed distance (ColliderDistance.h); 0 when no vertex is inside. Meshes have no inside (always 0).
double max_penetration(const std::vector<CensusInput>& cloths, const ColliderSet& colliders);

}  // namespace loom::collision
