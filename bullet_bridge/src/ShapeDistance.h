#pragma once
// Signed distance from a point to a collider's shape (private to the bridge; the contact fallback and the
// `loom compare` penetration metric use it). Negative inside. Conventions: Collider.h (local frames).
//   plane, sphere, capsule, box, cylinder: exact;
//   convex: max over the hull's face planes (exact inside; outside a lower bound, exact over faces);
//   mesh:   unsigned distance to the nearest triangle (two-sided, thickness only).
#include <vector>

#include "loom/collision/Collider.h"

namespace loom::bullet {

using collision::Transform;
using collision::Vec3;

// Face planes n·q <= d (unit outward n, local frame) of the convex hull of `points` (Bullet's
// btConvexHullComputer). Empty for fewer than 4 non-coplanar points.
struct HullPlanes {
  std::vector<Vec3> normals;
  std::vector<double> offsets;  // m
};
HullPlanes hull_planes(const std::vector<Vec3>& points);

// Distance (m) of world point p from `shape` placed at `pose`; *normal = unit world direction of increasing
// distance. `hull` is needed for convex shapes (hull_planes of shape.vertices).
double shape_signed_distance(const collision::Shape& shape, const HullPlanes* hull, const Transform& pose,
                             const Vec3& p, Vec3* normal);

}  // namespace loom::bullet
