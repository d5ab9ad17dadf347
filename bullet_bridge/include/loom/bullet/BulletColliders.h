#pragma once
// BulletColliders: the rigid bodies of a Bullet world near a cloth that is stepped outside the world (a
// character's garment, characters::GarmentInstance, through BulletGarment.h), as Loom colliders (Collider.h)
// that move over the cloth's frame, and the cloth's reactions handed back to the dynamic bodies.
// Bullet-free header (Bullet types forward-declared): include it from code that links loom::bullet.
//
// One frame, after the world's stepSimulation took the bodies from time t0 to t1 (the cloth's clock, s):
//   update(lo, hi, t0, t1): the broad phase lists the bodies whose AABB meets the box [lo, hi] inflated by
//     query_margin; each body's shape is mapped to colliders in its frame once (map_shape, BulletCloth.h;
//     static triangle meshes included) and placed in the world with a `motion` that moves it from its pose
//     at the last update (a body not seen then: its pose now stepped back along its velocities over t1 - t0)
//     to its pose now, over [t0, t1]: rotation by slerp, translation linear, clamped outside the interval;
//   the cloth steps against colliders() (its contact stage samples the motions at each step's ends and sums
//     its reactions into the colliders);
//   apply_reactions(): each dynamic body gets the summed reaction of its colliders as a central impulse and
//     the moment about its centre of mass as a torque impulse (activate()d), and the sums are cleared.
//     The contact stage sums moments about each collider's origin at the end of each step; they are carried
//     to the body's centre of mass at t1, which is exact when the body does not move within the frame and
//     otherwise off by the frame's displacement times the impulse.
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "loom/collision/Collider.h"

class btCollisionWorld;
class btRigidBody;

namespace loom::bullet {

struct BulletCollidersSettings {
  double query_margin = 0.1;     // m, >= 0: inflation of the cloth's box for the broad-phase query
  double thickness = 0.0;        // m, >= 0: the colliders' contact offset (0: the contact stage's own)
  double friction = 0.3;         // 1, >= 0: kinetic Coulomb coefficient, cloth against bodies
  double static_friction = 0.4;  // 1, >= friction: static coefficient
  bool reactions = true;         // apply_reactions pushes the dynamic bodies (false: bodies feel nothing)
};

class BulletColliders {
 public:
  // Throws loom::Error(source, "query_margin" / "thickness" / "friction" / "static_friction", ...) for a
  // negative or non-finite value (static_friction: below friction), and for a null world.
  BulletColliders(btCollisionWorld* world, const BulletCollidersSettings& settings = {},
                  const std::string& source = "bullet_colliders");
  ~BulletColliders();
  BulletColliders(const BulletColliders&) = delete;
  BulletColliders& operator=(const BulletColliders&) = delete;

  // Rebuilds colliders() from the bodies near [lo, hi] (m, world) for a cloth frame from t0 to t1 (s,
  // t1 >= t0). Throws loom::Error(source, "box" / "time", ...) for a non-finite or inverted box or interval.
  void update(const collision::Vec3& lo, const collision::Vec3& hi, double t0, double t1);
  // The reactions summed since update() go to the dynamic bodies (settings.reactions), then are cleared.
  void apply_reactions();

  // The same set object for the instance's lifetime (hand it to the cloth once).
  const collision::ColliderSetPtr& colliders() const { return colliders_; }
  // The bodies of the last update, in broad-phase order, and per collider the index of its body there.
  const std::vector<btRigidBody*>& bodies() const { return bodies_; }
  const std::vector<int>& collider_body() const { return collider_body_; }
  // Wake-up of a sleeping cloth: each body has a reference pose, the pose it had at its first update after
  // the last reset_references() call (a body that left the query box and came back: since it came back).
  // moved_boxes lists the world AABBs (m) of the last update's non-static bodies now farther than `distance`
  // (m) or turned more than `angle` (rad) from their reference pose.
  void reset_references() { ++epoch_; }
  std::vector<std::pair<collision::Vec3, collision::Vec3>> moved_boxes(double distance, double angle) const;
  // Summed impulse (N s) apply_reactions gave `body` since construction.
  collision::Vec3 applied_impulse(const btRigidBody* body) const;
  // Unsupported shape names met (each once, in order).
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  struct Track;
  Track& track(btRigidBody* body);

  btCollisionWorld* world_;
  BulletCollidersSettings settings_;
  std::string source_;
  collision::ColliderSetPtr colliders_;
  std::vector<btRigidBody*> bodies_;
  std::vector<int> collider_body_;
  std::map<const btRigidBody*, std::unique_ptr<Track>> tracks_;  // the bodies of the last update
  std::map<const btRigidBody*, collision::Vec3> applied_;        // N s, per body ever pushed
  std::vector<std::string> warnings_;
  long updates_ = 0;
  long epoch_ = 0;  // reset_references count
};

}  // namespace loom::bullet
