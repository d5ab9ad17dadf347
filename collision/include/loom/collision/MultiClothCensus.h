#pragma once
// The exact intersection census over several cloths (`loom run --census`): the self census of each
// cloth (IntersectionCensus.h: intersecting pairs of triangles sharing no vertex) plus, for every pair of
// cloths, the count of intersecting triangle pairs between them (all pairs: two cloths share no vertex).
// Exact predicates (ExactPredicates.h); the count is independent of the thread count.
#include <csignal>
#include <optional>
#include <vector>

#include "loom/cloth/ClothMesh.h"
#include "loom/collision/ClothBvh.h"
#include "loom/collision/Collider.h"
#include "loom/collision/IntersectionCensus.h"

namespace loom::collision {

struct CensusInput {
  const loom::cloth::ClothMesh* mesh = nullptr;
  const loom::cloth::Vec3s* x = nullptr;  // m, one position per mesh vertex
};

// Intersecting triangle pairs between two different cloths. `stop` and `bound` as for
// count_intersecting_pairs (IntersectionCensus.h): once stopped, -1; past the bound, CensusBoundExceeded
// (cloths 0 and 1).
long count_intersecting_pairs_between(const CensusInput& a, const CensusInput& b, int threads = 1,
                                      const volatile std::sig_atomic_t* stop = nullptr,
                                      long bound = kCensusCandidateBound);
// Self census of every cloth plus every cloth pair; -1 once `stop` is set. `bound` holds for the whole call
// (all cloths and pairs together); past it, CensusBoundExceeded names the cloths (indices into `cloths`)
// being walked.
long count_all_intersections(const std::vector<CensusInput>& cloths, int threads = 1,
                             const volatile std::sig_atomic_t* stop = nullptr,
                             long bound = kCensusCandidateBound);
// One intersecting triangle pair: triangle tri_a of cloth cloth_a and triangle tri_b of cloth cloth_b
// (indices into the census input), (cloth_a, tri_a) < (cloth_b, tri_b); within one cloth the two share no
// vertex.
struct IntersectingPair {
  int cloth_a = 0, tri_a = 0, cloth_b = 0, tri_b = 0;
  bool operator<(const IntersectingPair& o) const;
  bool operator==(const IntersectingPair& o) const;
};
// Every intersecting pair (the same pairs count_all_intersections counts), sorted. `trees`: one ClothBvh per
// cloth whose leaf boxes hold the triangles at `x` (refit or rebuilt on x, any thickness >= 0); a caller that
// checks every step keeps its trees and refits them (ClothBvh::update). The result does not depend on the
// trees' topology nor on the thread count. With cone_margin >= 0 (m), the self pairs of a patch that is a
// height field with a simple contour (ClothBvh::self_pairs_culled at x0 = x1 = x, that margin) are skipped:
// such a patch cannot intersect itself (its projection along the cone axis is one-to-one), so the pairs are
// the same, found faster on smooth cloth.
std::vector<IntersectingPair> intersecting_pairs(const std::vector<CensusInput>& cloths,
                                                 const std::vector<const ClothBvh*>& trees, int threads = 1,
                                                 double cone_margin = -1.0);
// The same with trees built here.
std::vector<IntersectingPair> intersecting_pairs(const std::vector<CensusInput>& cloths, int threads = 1);
// Cloths whose triangles start piled onto each other (a triangle soup, a mesh scaled to a point): pairs of
// triangles whose boxes overlap at x (within one cloth those sharing no vertex, and all pairs between two
// cloths), counted without exact tests. The pairs of (a, b) pass the bound when they exceed
// max(kPiledPairsMin, kPiledPairsPerTriangle x the triangles of a and b): a cloth at rest or draped has a
// few such pairs per triangle (its folds), a pile about as many as it has triangles, and every self- and
// cloth-cloth collision stage would test them all at every step. Returns the first (a, b) past the bound
// (a == b: within one cloth; only with `self`, when the stages test pairs within a cloth) with its count so
// far, or nothing.
constexpr long kPiledPairsMin = 1'000'000;
constexpr long kPiledPairsPerTriangle = 64;
struct PiledCloths {
  int cloth_a = 0, cloth_b = 0;
  long pairs = 0;  // counted until past the bound
  long bound = 0;
};
std::optional<PiledCloths> piled_cloths(const std::vector<CensusInput>& cloths, bool self, int threads = 1);
// Largest depth (m) of any cloth vertex inside any collider at its current pose (`curr`), by the collider's
// signed distance (ColliderDistance.h); 0 when no vertex is inside. Meshes have no inside (always 0).
double max_penetration(const std::vector<CensusInput>& cloths, const ColliderSet& colliders);

}  // namespace loom::collision
