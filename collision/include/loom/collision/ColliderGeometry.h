#pragma once
// ColliderGeometry: what a convex or mesh collider needs beyond its Shape, built once.
//   convex: the hull of Shape::vertices (Qhull, Barber et al. 1996, "The Quickhull algorithm for convex
//           hulls"), as outward face planes (the signed distance inside is the largest plane distance) and
//           as an fcl::Convex (GJK through libccd for the distance outside);
//   mesh:   an fcl::BVHModel<OBBRSS> of the triangles in the local frame, never refitted (the mesh is rigid;
//           FCL's refitted OBBRSS trees give wrong distances).
// Both carry the local bounding box. The FCL objects are behind FclShape (src/FclShape.h), so including this
// header does not pull in FCL.
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "loom/collision/Collider.h"

namespace loom::collision {

struct FclShape;  // src/FclShape.h

struct ColliderGeometry {
  std::vector<Vec3> hull_vertices;           // m, local: convex only, the hull's vertices
  std::vector<Tri> hull_triangles;           // convex only: the hull's faces, triangulated, outward
  std::vector<Eigen::Vector4d> hull_planes;  // convex only: (n, d), outward unit n, n.x = d on the face
  std::shared_ptr<const FclShape> fcl;       // fcl::Convex or fcl::BVHModel<OBBRSS>
  Vec3 local_lo = Vec3::Zero(), local_hi = Vec3::Zero();  // m, bounding box in the local frame
};

// Builds the geometry of a convex or mesh shape (throws loom::Error naming `where` for bad input: fewer than
// 4 non-coplanar points, an empty mesh, an out-of-range triangle); null for the analytic shapes.
std::shared_ptr<const ColliderGeometry> build_collider_geometry(const Shape& shape,
                                                                const std::string& where = "");
// Fills c.geometry when the shape needs one and it is missing.
void prepare_collider(Collider& c);

// Local-frame bounding box of any shape except the plane (m). For convex/mesh uses `geometry` when given.
void local_bounds(const Shape& shape, const ColliderGeometry* geometry, Vec3& lo, Vec3& hi);

}  // namespace loom::collision
