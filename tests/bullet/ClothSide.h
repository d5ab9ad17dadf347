#pragma once
// Bodies through the cloth of a BulletScene: bullet::BodyCrossings (a body is through when its centre meets
// the cloth's surface between two frames), and the side of each body.
// The side of the cloth (ray casts along its rest normal n: the segment c -> c + kReach n crosses the cloth
// k times, the side is k mod 2) is tracked too: a side change without a surface crossing is a body round
// the border (sides_changed_round_border).
// A body marked kSkip (one the cloth is attached to: the ray starts on the cloth's attached vertices and its
// centre sits by the cloth) is not checked; kOverOnly (a kinematic body whose script carries it across the
// cloth's border, as the toy box's paddle) is checked as kAlways.
#include <algorithm>
#include <utility>
#include <vector>

#include "loom/bullet/BodyCrossings.h"
#include "loom/bullet/BulletScene.h"
#include "loom/cloth/Simulation.h"

namespace loom::test {

using bullet::centre_meets_cloth;

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
      : scene_(scene),
        n_(normal),
        mode_(std::move(modes)),
        crossings_(meshes(scene), positions(), centres(), crossing_modes(mode_, scene)) {
    mode_.resize(scene.num_bodies(), kAlways);
    for (size_t b = 0; b < scene.num_bodies(); ++b) side_.push_back(side(b));
  }
  // k mod 2; -1 for a skipped body.
  int side(size_t b) const {
    if (mode_[b] == kSkip) return -1;
    const cloth::Vec3 c = scene_.body_position(b);
    return crossings(scene_, c, c + kReach * n_) % 2;
  }
  // Checks every body (call once per frame); returns how many met the cloth's surface since the last call.
  int update() {
    const int through = crossings_.update(positions(), centres());
    for (size_t b = 0; b < side_.size(); ++b) {
      if (mode_[b] == kSkip) continue;
      const int s = side(b);
      if (!crossings_.met_last(b) && s != side_[b]) ++round_border_;
      side_[b] = s;
    }
    return through;
  }
  // Bodies that met the cloth's surface at least once so far.
  int bodies_through() const { return crossings_.bodies_through(); }
  bool crossed(size_t b) const { return crossings_.crossed(b); }
  // Side changes (ray parity) with no surface crossing: bodies that went round the cloth's border.
  int sides_changed_round_border() const { return round_border_; }

 private:
  static std::vector<const cloth::ClothMesh*> meshes(const bullet::BulletScene& scene) {
    std::vector<const cloth::ClothMesh*> m;
    for (const auto& c : scene.simulation().cloths()) m.push_back(&c->mesh());
    return m;
  }
  static std::vector<char> crossing_modes(std::vector<char> modes, const bullet::BulletScene& scene) {
    modes.resize(scene.num_bodies(), kAlways);
    for (char& m : modes) m = m == kSkip ? bullet::BodyCrossings::kSkip : bullet::BodyCrossings::kAlways;
    return modes;
  }
  std::vector<cloth::Vec3s> positions() const {
    std::vector<cloth::Vec3s> x;
    for (const auto& c : scene_.simulation().cloths()) x.push_back(c->state().x);
    return x;
  }
  std::vector<cloth::Vec3> centres() const {
    std::vector<cloth::Vec3> c;
    for (size_t b = 0; b < scene_.num_bodies(); ++b) c.push_back(scene_.body_position(b));
    return c;
  }
  const bullet::BulletScene& scene_;
  cloth::Vec3 n_;
  std::vector<char> mode_;
  bullet::BodyCrossings crossings_;
  std::vector<int> side_;
  int round_border_ = 0;
};

}  // namespace loom::test
