#pragma once
// Ray casts against a cloth's triangles (picking a vertex to drag in loom-view; BulletCloth::ray_test).
// Two-sided ray-triangle test of Möller and Trumbore 1997 ("Fast, minimum storage ray-triangle
// intersection"); the cloth cast is brute force over all triangles, nearest hit first (a click is one
// cast, so O(triangles) is fine; ties go to the lower triangle index, so results do not depend on order
// of evaluation).
#include <limits>
#include <optional>
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::collision {

using loom::cloth::Tri;
using loom::cloth::Vec3;
using loom::cloth::Vec3s;

struct RayHit {
  int triangle = -1;                // index into the triangle list
  Vec3 barycentric = Vec3::Zero();  // 1, weights of the triangle's corners at the hit (sum 1)
  double distance = 0.0;            // m along the unit ray direction (origin + distance * dir is the hit)
};

// Hit of the ray origin + s * dir, 0 <= s <= max_distance, with triangle (a, b, c), either side; `dir`
// need not be unit (the distance is then in units of |dir|). Empty for no hit, a parallel ray or a
// degenerate triangle.
std::optional<RayHit> ray_triangle(const Vec3& origin, const Vec3& dir, const Vec3& a, const Vec3& b,
                                   const Vec3& c,
                                   double max_distance = std::numeric_limits<double>::infinity());

// Nearest hit of the ray with the triangles of a mesh at positions x (dir is normalised here, so the
// distance is in metres). Empty when the ray misses every triangle.
std::optional<RayHit> ray_cast(const Vec3& origin, const Vec3& dir, const Vec3s& x,
                               const std::vector<Tri>& triangles,
                               double max_distance = std::numeric_limits<double>::infinity());

// The triangle corner nearest to the hit point (largest barycentric weight).
inline int nearest_corner(const RayHit& hit, const std::vector<Tri>& triangles) {
  int k = 0;
  hit.barycentric.maxCoeff(&k);
  return triangles[hit.triangle][k];
}

}  // namespace loom::collision
