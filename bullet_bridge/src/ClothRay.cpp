#include "loom/bullet/ClothRay.h"

#include <algorithm>
#include <cmath>

namespace loom::bullet {

namespace {

// Möller-Trumbore: segment from + s (to - from), s in [0, 1]; returns s or -1, and barycentric (u, v).
double segment_triangle(const Vec3& from, const Vec3& dir, const Vec3& a, const Vec3& b, const Vec3& c,
                        double& u, double& v) {
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 p = dir.cross(e2);
  const double det = e1.dot(p);
  if (det == 0.0) return -1.0;  // parallel (or degenerate triangle)
  const double inv = 1.0 / det;
  const Vec3 t = from - a;
  u = t.dot(p) * inv;
  if (u < 0.0 || u > 1.0) return -1.0;
  const Vec3 q = t.cross(e1);
  v = dir.dot(q) * inv;
  if (v < 0.0 || u + v > 1.0) return -1.0;
  const double s = e2.dot(q) * inv;
  return (s >= 0.0 && s <= 1.0) ? s : -1.0;
}

void test_triangle(const cloth::ClothMesh& mesh, const Vec3s& x, const Vec3& from, const Vec3& dir, int k,
                   double& best_s, RayHit& hit) {
  const cloth::Tri& t = mesh.triangles()[k];
  double u = 0.0, v = 0.0;
  const double s = segment_triangle(from, dir, x[t[0]], x[t[1]], x[t[2]], u, v);
  if (s < 0.0 || !(s < best_s)) return;
  best_s = s;
  hit.hit = true;
  hit.triangle = k;
  hit.barycentric = Vec3(1.0 - u - v, u, v);
}

}  // namespace

RayHit ray_triangles(const cloth::ClothMesh& mesh, const Vec3s& x, const Vec3& from, const Vec3& to,
                     const std::vector<int>* candidates) {
  RayHit hit;
  const Vec3 dir = to - from;
  double best_s = HUGE_VAL;
  if (candidates) {
    for (int k : *candidates) test_triangle(mesh, x, from, dir, k, best_s, hit);
  } else {
    for (int k = 0; k < mesh.num_triangles(); ++k) test_triangle(mesh, x, from, dir, k, best_s, hit);
  }
  if (hit.hit) {
    hit.distance = best_s * dir.norm();
    hit.point = from + best_s * dir;
  }
  return hit;
}

ClothRayCaster::ClothRayCaster(std::shared_ptr<const cloth::ClothMesh> mesh) : mesh_(mesh), bvh_(mesh) {
  double sum = 0.0;
  int n = 0;
  for (const cloth::Tri& t : mesh_->triangles()) {
    sum += (mesh_->rest_positions()[t[0]] - mesh_->rest_positions()[t[1]]).norm();
    ++n;
  }
  cell_ = n > 0 ? 4.0 * sum / n : 1.0;
}

RayHit ClothRayCaster::cast(const Vec3s& x, const Vec3& from, const Vec3& to) {
  bvh_.refit(x, x, 0.0);
  // The segment in pieces, each inside its own box: the union of the pieces' candidates holds every
  // triangle the segment can hit.
  const double len = (to - from).norm();
  const int pieces = std::clamp(static_cast<int>(std::ceil(len / cell_)), 1, 256);
  std::vector<int> cand;
  for (int p = 0; p < pieces; ++p) {
    collision::Aabb box;
    box.grow(from + (to - from) * (static_cast<double>(p) / pieces));
    box.grow(from + (to - from) * (static_cast<double>(p + 1) / pieces));
    // Pad by a relative epsilon so round-off in the piece ends never drops a triangle.
    const double pad = 1e-9 * (1.0 + from.cwiseAbs().maxCoeff() + to.cwiseAbs().maxCoeff());
    box.lo.array() -= pad;
    box.hi.array() += pad;
    const std::vector<int> q = bvh_.query(box);
    cand.insert(cand.end(), q.begin(), q.end());
  }
  std::sort(cand.begin(), cand.end());
  cand.erase(std::unique(cand.begin(), cand.end()), cand.end());
  return ray_triangles(*mesh_, x, from, to, &cand);
}

}  // namespace loom::bullet
