#pragma once
// Proximity primitives: point-triangle and segment-segment distances, in double (with the closest points, for
// response) and exactly (squared distance as a GMP rational of the double inputs, for tests and the census).
// Both come from one template (Distance.cpp), so the exact version checks the region logic of the double one.
// Method: the minimum of a convex quadratic over a simplex (or the unit square) lies at the interior
// stationary point if that is feasible, else on the boundary (Ericson 2005, "Real-Time Collision Detection",
// Sec. 5.1.2-5.1.9); the boundary is reduced to point-segment distances, which makes degenerate input
// (zero-area triangles, parallel or zero-length segments) exact without tolerances.
#include <gmpxx.h>

#include "loom/cloth/Types.h"

namespace loom::collision {

using loom::cloth::Vec3;

struct PointTriangleClosest {
  double distance_squared = 0;  // m^2
  Vec3 weights = Vec3::Zero();  // 1; barycentric weights of the closest point on (a, b, c), summing to 1
};

struct SegmentSegmentClosest {
  double distance_squared = 0;  // m^2
  double s = 0;                 // 1; closest point p0 + s (p1 - p0)
  double t = 0;                 // 1; closest point q0 + t (q1 - q0)
};

// Distance (m) from p to the segment (a, b); a zero-length segment is the point a.
double point_segment_distance(const Vec3& p, const Vec3& a, const Vec3& b);

PointTriangleClosest point_triangle_closest(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);
SegmentSegmentClosest segment_segment_closest(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1);

// Exact squared distances (m^2) of the double inputs, as rationals.
mpq_class point_triangle_distance_squared_exact(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);
mpq_class segment_segment_distance_squared_exact(const Vec3& p0, const Vec3& p1, const Vec3& q0,
                                                 const Vec3& q1);

}  // namespace loom::collision
