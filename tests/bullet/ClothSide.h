#pragma once
// Which side of a cloth a body is on, from ray casts (BulletScene::ray_test): the segment from the body's
// centre c to c + kReach n (n: the cloth's rest normal) crosses the cloth k times; the side is k mod 2. A
// body changes side only by passing through the cloth or round its border; the scenes tested drop or throw
// bodies onto the cloth's middle, so every change of side is counted as a body through the cloth.
// A body marked kOverOnly (a kinematic body whose script carries it across the cloth's border, as the
// toy box's paddle) is checked only while it is over the cloth (the line c +- kReach n meets it): its side
// is taken when it comes over the cloth and a change counts only between two positions over the cloth.
// A body marked kSkip (one the cloth is attached to: the ray starts on the cloth's attached vertices) is
// not checked.
#include <utility>
#include <vector>

#include "loom/bullet/BulletScene.h"
#include "loom/cloth/Simulation.h"

namespace loom::test {

// Area-weighted unit normal of cloth `c` at its rest positions (the plane of a flat grid).
inline cloth::Vec3 rest_normal(const cloth::Simulation& sim, int c = 0) {
  const cloth::ClothMesh& m = sim.cloths()[c]->mesh();
  cloth::Vec3 n = cloth::Vec3::Zero();
  for (const cloth::Tri& t : m.triangles()) {
    const auto& x = m.rest_positions();
    n += (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);
  }
  return n.normalized();
}

// Number of cloth crossings of the segment from -> to, counting hits that coincide (a shared edge) once.
inline int crossings(const bullet::BulletScene& scene, const cloth::Vec3& from, const cloth::Vec3& to) {
  int k = 0;
  cloth::Vec3 a = from;
  const cloth::Vec3 dir = (to - from).normalized();
  for (int guard = 0; guard < 1000; ++guard) {
    const bullet::RayHit h = scene.ray_test(a, to);
    if (!h.hit) break;
    ++k;
    a = h.point + 1e-7 * dir;
    if ((to - a).dot(dir) <= 0.0) break;
  }
  return k;
}

class ClothSideTracker {
 public:
  static constexpr double kReach = 10.0;  // m
  enum Mode : char { kAlways = 0, kOverOnly = 1, kSkip = 2 };
  ClothSideTracker(const bullet::BulletScene& scene, const cloth::Vec3& normal, std::vector<char> modes = {})
      : scene_(scene), n_(normal), mode_(std::move(modes)) {
    mode_.resize(scene.num_bodies(), kAlways);
    for (size_t b = 0; b < scene.num_bodies(); ++b) side_.push_back(side(b));
    crossed_.assign(side_.size(), 0);
  }
  // k mod 2; -1 for a skipped body and for a kOverOnly body that is not over the cloth.
  int side(size_t b) const {
    if (mode_[b] == kSkip) return -1;
    const cloth::Vec3 c = scene_.body_position(b);
    const int up = crossings(scene_, c, c + kReach * n_);
    if (mode_[b] == kOverOnly && up == 0 && crossings(scene_, c, c - kReach * n_) == 0) return -1;
    return up % 2;
  }
  // Checks every body (call once per frame); returns how many changed side since the last call.
  int update() {
    int changed = 0;
    for (size_t b = 0; b < side_.size(); ++b) {
      const int s = side(b);
      if (s < 0) continue;  // kSkip, or kOverOnly and off the cloth: keeps the side it had over it
      if (side_[b] >= 0 && s != side_[b]) ++changed, crossed_[b] = 1;
      side_[b] = s;
    }
    return changed;
  }
  // Bodies that changed side at least once so far.
  int bodies_through() const {
    int k = 0;
    for (char c : crossed_) k += c;
    return k;
  }
  bool crossed(size_t b) const { return crossed_[b] != 0; }

 private:
  const bullet::BulletScene& scene_;
  cloth::Vec3 n_;
  std::vector<char> mode_;
  std::vector<int> side_;
  std::vector<char> crossed_;
};

}  // namespace loom::test
