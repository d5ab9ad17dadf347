#pragma once
// Bodies through a cloth. A body is through when its centre meets the cloth's surface: between two calls
// the centre moves linearly from c0 to c1 and each triangle's vertices linearly from their old to their new
// positions, and a vertex-face continuous test (collision::vertex_face_ccd, conservative) of the centre
// against any triangle hits (centre_meets_cloth). A body that goes round the cloth's border (under a free
// hem that swings out with it) never meets the surface and is not counted.
// The side of the cloth (ray casts along its rest normal n: the segment c -> c + kReach n crosses the cloth
// k times, the side is k mod 2) is tracked too: a side change without a surface crossing is a body round
// the border (sides_changed_round_border).
// A body marked kSkip (one the cloth is attached to: the ray starts on the cloth's attached vertices and its
// centre sits by the cloth) is not checked; kOverOnly (a kinematic body whose script carries it across the
// cloth's border, as the toy box's paddle) is checked as kAlways.
#include <algorithm>
#include <utility>
#include <vector>

#include "loom/bullet/BulletScene.h"
#include "loom/cloth/Simulation.h"
#include "loom/collision/Ccd.h"

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

// True when a point moving linearly c0 -> c1 meets a triangle of `mesh` whose vertices move linearly
// x0 -> x1 over the same interval (a swept-box cull, then collision::vertex_face_ccd).
inline bool centre_meets_cloth(const cloth::ClothMesh& mesh, const cloth::Vec3s& x0, const cloth::Vec3s& x1,
                               const cloth::Vec3& c0, const cloth::Vec3& c1) {
  const cloth::Vec3 plo = c0.cwiseMin(c1), phi = c0.cwiseMax(c1);
  for (const cloth::Tri& t : mesh.triangles()) {
    cloth::Vec3 lo = x0[t[0]], hi = x0[t[0]];
    for (int k = 0; k < 3; ++k) {
      lo = lo.cwiseMin(x0[t[k]]).cwiseMin(x1[t[k]]);
      hi = hi.cwiseMax(x0[t[k]]).cwiseMax(x1[t[k]]);
    }
    if ((lo.array() > phi.array()).any() || (hi.array() < plo.array()).any()) continue;
    if (collision::vertex_face_ccd(c0, x0[t[0]], x0[t[1]], x0[t[2]], c1, x1[t[0]], x1[t[1]], x1[t[2]]).hit)
      return true;
  }
  return false;
}

class ClothSideTracker {
 public:
  static constexpr double kReach = 10.0;  // m
  enum Mode : char { kAlways = 0, kOverOnly = 1, kSkip = 2 };
  ClothSideTracker(const bullet::BulletScene& scene, const cloth::Vec3& normal, std::vector<char> modes = {})
      : scene_(scene), n_(normal), mode_(std::move(modes)) {
    mode_.resize(scene.num_bodies(), kAlways);
    for (size_t b = 0; b < scene.num_bodies(); ++b) {
      side_.push_back(side(b));
      centre_.push_back(scene.body_position(b));
    }
    crossed_.assign(side_.size(), 0);
    x_ = positions();
  }
  // k mod 2; -1 for a skipped body.
  int side(size_t b) const {
    if (mode_[b] == kSkip) return -1;
    const cloth::Vec3 c = scene_.body_position(b);
    return crossings(scene_, c, c + kReach * n_) % 2;
  }
  // Checks every body (call once per frame); returns how many met the cloth's surface since the last call.
  int update() {
    const std::vector<cloth::Vec3s> x = positions();
    const auto& cloths = scene_.simulation().cloths();
    int through = 0;
    for (size_t b = 0; b < side_.size(); ++b) {
      const cloth::Vec3 c = scene_.body_position(b);
      if (mode_[b] != kSkip) {
        bool met = false;
        for (size_t k = 0; k < cloths.size() && !met; ++k)
          met = centre_meets_cloth(cloths[k]->mesh(), x_[k], x[k], centre_[b], c);
        const int s = side(b);
        if (met) ++through, crossed_[b] = 1;
        if (!met && s != side_[b]) ++round_border_;
        side_[b] = s;
      }
      centre_[b] = c;
    }
    x_ = x;
    return through;
  }
  // Bodies that met the cloth's surface at least once so far.
  int bodies_through() const {
    int k = 0;
    for (char c : crossed_) k += c;
    return k;
  }
  bool crossed(size_t b) const { return crossed_[b] != 0; }
  // Side changes (ray parity) with no surface crossing: bodies that went round the cloth's border.
  int sides_changed_round_border() const { return round_border_; }

 private:
  std::vector<cloth::Vec3s> positions() const {
    std::vector<cloth::Vec3s> x;
    for (const auto& c : scene_.simulation().cloths()) x.push_back(c->state().x);
    return x;
  }
  const bullet::BulletScene& scene_;
  cloth::Vec3 n_;
  std::vector<char> mode_;
  std::vector<int> side_;
  std::vector<cloth::Vec3> centre_;  // m, body centres at the last call
  std::vector<cloth::Vec3s> x_;      // m, cloth positions at the last call
  std::vector<char> crossed_;
  int round_border_ = 0;
};

}  // namespace loom::test
