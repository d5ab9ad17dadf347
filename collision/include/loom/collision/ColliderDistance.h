#pragma once
// Signed distance from a point to a collider: negative inside, with the outward unit normal (the
// distance's gradient). Closed forms for plane, sphere, capsule, box and cylinder (the exact Euclidean
// signed distance of each solid; e.g. Quilez, "distance functions", and Ericson 2005, "Real-Time Collision
// Detection", Sec. 5.1); convex hulls: outside by GJK through FCL/libccd (Gilbert, Johnson, Keerthi 1988),
// inside as the largest face-plane distance (exact for a convex polytope); static meshes: the unsigned
// distance to the nearest triangle through FCL's OBBRSS tree (two-sided: a mesh has no inside, only its
// thickness). Every one of these is 1-Lipschitz in the point, which the swept tests rely on.
#include "loom/collision/Collider.h"
#include "loom/collision/ColliderGeometry.h"

namespace loom::collision {

// Signed distance (m) from world point p to collider c placed at `pose`; *normal (may be null) receives the
// outward unit normal in world coordinates. Convex and mesh shapes use c.geometry when prepared
// (prepare_collider), else build it for this call (slow: prepare colliders that are queried often).
double signed_distance(const Collider& c, const Transform& pose, const Vec3& p, Vec3* normal);

// The same in the shape's local frame (point q, normal in the local frame).
double local_signed_distance(const Shape& shape, const ColliderGeometry* geometry, const Vec3& q,
                             Vec3* normal);

// Distance (m) from the segment (a, b) to a capsule's axis minus its radius (negative: the segment enters the
// capsule), at `pose`; *s = closest parameter on (a, b), *normal = unit direction from the axis to the
// segment's closest point (world). Used so coarse cloth edges cannot slip between capsules.
double segment_capsule_distance(const Collider& capsule, const Transform& pose, const Vec3& a, const Vec3& b,
                                double* s, Vec3* normal);

// Signed distance (m) from the segment (a, b) to a box collider at `pose`, for edge contacts. Outside: the
// distance to the nearest of the box's 12 edges, *s = the closest parameter on (a, b), *normal = the unit
// direction from that edge to the segment. A segment that enters the box: minus the depth of the minimum
// translation out of it (separating axes), *normal = that direction (world), *s = the deepest parameter:
// 0 or 1 when that end is inside the box (the end's contact, not the edge's), 0.5 when the deepest point is
// an end outside the box (the whole segment is moved).
// With `past` (the segment's ends and the box's pose at the step's start), a segment that enters the box
// leaves on a side it was separated on then, if there is one.
struct SegmentPast {
  Vec3 a, b;
  Transform pose;
};
double segment_box_edges_distance(const Collider& box, const Transform& pose, const Vec3& a, const Vec3& b,
                                  double* s, Vec3* normal, const SegmentPast* past = nullptr);

}  // namespace loom::collision
