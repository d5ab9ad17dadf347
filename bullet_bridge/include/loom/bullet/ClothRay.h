#pragma once
// Ray (segment) casts against a cloth's triangles (picking, bullets, line of sight). Bullet-free.
// The triangle test is Möller & Trumbore (1997, "Fast, minimum storage ray/triangle intersection") in double,
// two-sided; the nearest hit wins, ties go to the lower triangle index. ClothRayCaster culls with the cloth
// BVH (collision/ClothBvh.h) along the segment and runs the same exact test on the candidates, so it returns
// exactly what the brute-force loop returns.
#include <memory>
#include <vector>

#include "loom/cloth/ClothMesh.h"
#include "loom/collision/ClothBvh.h"

namespace loom::bullet {

using cloth::Vec3;
using cloth::Vec3s;

struct RayHit {
  bool hit = false;
  int cloth = -1;                   // index of the cloth in its simulation (BulletCloth::ray_test)
  int triangle = -1;                // triangle index in the cloth's mesh
  Vec3 barycentric = Vec3::Zero();  // 1, weights of the triangle's vertices (sum 1)
  double distance = 0.0;            // m, from `from` to the hit point
  Vec3 point = Vec3::Zero();        // m
};

// Nearest hit over all triangles (brute force), or over `candidates` (sorted triangle indices) if given.
RayHit ray_triangles(const cloth::ClothMesh& mesh, const Vec3s& x, const Vec3& from, const Vec3& to,
                     const std::vector<int>* candidates = nullptr);

class ClothRayCaster {
 public:
  explicit ClothRayCaster(std::shared_ptr<const cloth::ClothMesh> mesh);
  // Refits the BVH to positions x (m) and casts.
  RayHit cast(const Vec3s& x, const Vec3& from, const Vec3& to);

 private:
  std::shared_ptr<const cloth::ClothMesh> mesh_;
  collision::ClothBvh bvh_;
  double cell_ = 0.0;  // m, segment piece length for BVH queries (a few rest edge lengths)
};

}  // namespace loom::bullet
