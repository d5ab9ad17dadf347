#include "loom/collision/RayCast.h"

#include <cmath>

namespace loom::collision {

std::optional<RayHit> ray_triangle(const Vec3& origin, const Vec3& dir, const Vec3& a, const Vec3& b,
                                   const Vec3& c, double max_distance) {
  // Möller-Trumbore 1997: solve origin + s dir = a + u (b - a) + v (c - a) by Cramer's rule.
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 p = dir.cross(e2);
  const double det = e1.dot(p);
  // Parallel ray or degenerate triangle: |det| tiny relative to the sizes involved.
  const double scale = dir.norm() * e1.norm() * e2.norm();
  if (!(std::abs(det) > 1e-14 * scale)) return std::nullopt;
  const double inv = 1.0 / det;
  const Vec3 tv = origin - a;
  const double u = tv.dot(p) * inv;
  if (u < 0.0 || u > 1.0) return std::nullopt;
  const Vec3 q = tv.cross(e1);
  const double v = dir.dot(q) * inv;
  if (v < 0.0 || u + v > 1.0) return std::nullopt;
  const double s = e2.dot(q) * inv;
  if (s < 0.0 || s > max_distance) return std::nullopt;
  RayHit hit;
  hit.barycentric = Vec3(1.0 - u - v, u, v);
  hit.distance = s;
  return hit;
}

std::optional<RayHit> ray_cast(const Vec3& origin, const Vec3& dir, const Vec3s& x,
                               const std::vector<Tri>& triangles, double max_distance) {
  const double len = dir.norm();
  if (!(len > 0.0) || !std::isfinite(len)) return std::nullopt;
  const Vec3 d = dir / len;
  std::optional<RayHit> best;
  for (size_t i = 0; i < triangles.size(); ++i) {
    const Tri& t = triangles[i];
    const double limit = best ? best->distance : max_distance;
    std::optional<RayHit> h = ray_triangle(origin, d, x[t[0]], x[t[1]], x[t[2]], limit);
    if (h && (!best || h->distance < best->distance)) {  // strict: ties keep the lower index
      h->triangle = static_cast<int>(i);
      best = h;
    }
  }
  return best;
}

}  // namespace loom::collision
