#pragma once
// BulletGarment: a character's garment (characters::GarmentInstance) in a Bullet world: the garment also
// collides with the world's rigid bodies and static meshes (a cape brushing a wall or pushing a crate), the
// dynamic bodies receive the garment's reaction, and a moving body touching a sleeping garment wakes it.
// The game loop, each frame:
//   world.stepSimulation(frame_dt, ...);   // the bodies move from t0 to t1 = t0 + frame_dt
//   garment.set_pose(bones);
//   bullet_garment.step(frame_dt);          // instead of garment.step(frame_dt)
// step(): BulletColliders::update over the box of the garment's positions and skinned mesh (the bodies near
// it, moving from their poses at the last frame to now over the garment's frame), wake-up of a sleeping
// garment (a non-static body now farther than wake_distance or turned more than wake_rotation from where it
// was when the garment fell asleep, or where it was first seen after that, and whose box meets the
// garment's: notify_contact),
// garment.step(frame_dt) with the bodies as external colliders (GarmentInstance::set_colliders, the real-time
// contact after the skin constraints), then BulletColliders::apply_reactions.
// Header-only glue between loom::bullet and loom::characters: include it from code that links both.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "loom/bullet/BulletColliders.h"
#include "loom/characters/GarmentInstance.h"
#include "loom/cloth/Error.h"

namespace loom::bullet {

struct BulletGarmentSettings {
  BulletCollidersSettings bodies;              // broad-phase margin, friction, contact offset, reactions
  collision::RealtimeContactSettings contact;  // the garment's contact stage (thickness 0: the fabric's)
  bool wake_on_contact = true;                 // a moving body touching a sleeping garment wakes it
  double wake_distance = 0.005;                // m, >= 0: a body moved farther than this wakes the garment
  double wake_rotation = 0.02;                 // rad, >= 0: or turned more than this
};

class BulletGarment {
 public:
  // The garment must outlive this object; the destructor removes the colliders from it. Throws loom::Error
  // (source, field, problem) for bad settings (BulletColliders, GarmentInstance::set_colliders,
  // "wake_distance", "wake_rotation").
  BulletGarment(characters::GarmentInstance& garment, btCollisionWorld* world,
                const BulletGarmentSettings& settings = {}, const std::string& source = "bullet_garment")
      : garment_(garment), bodies_(world, settings.bodies, source), settings_(settings), source_(source) {
    for (auto [value, field] : {std::pair{settings.wake_distance, "wake_distance"},
                                std::pair{settings.wake_rotation, "wake_rotation"}})
      if (!(value >= 0.0) || !std::isfinite(value))
        throw Error(source, field, std::to_string(value) + " must be finite and >= 0");
    garment_.set_colliders(bodies_.colliders(), settings.contact);
  }
  ~BulletGarment() { garment_.set_colliders(nullptr); }
  BulletGarment(const BulletGarment&) = delete;
  BulletGarment& operator=(const BulletGarment&) = delete;

  // One frame of frame_dt (s, finite, >= 0), after the world's stepSimulation and the garment's set_pose.
  // Throws loom::Error(source, "frame_dt", ...) otherwise.
  void step(double frame_dt) {
    if (!(frame_dt >= 0.0) || !std::isfinite(frame_dt))
      throw Error(source_, "frame_dt", std::to_string(frame_dt) + " must be finite and >= 0");
    collision::Vec3 lo = garment_.positions()[0], hi = lo;
    for (const cloth::Vec3s* xs : {&garment_.positions(), &garment_.skinned()})
      for (const collision::Vec3& p : *xs) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    const double t0 = garment_.clock();
    bodies_.update(lo, hi, t0, t0 + frame_dt);
    if (settings_.wake_on_contact && garment_.asleep())
      for (const auto& [a, b] : bodies_.moved_boxes(settings_.wake_distance, settings_.wake_rotation))
        garment_.notify_contact(a, b);
    garment_.step(frame_dt);
    bodies_.apply_reactions();
    // Awake, the references follow the bodies: asleep, a body wakes the garment once it has moved from
    // where it was when the garment fell asleep (or, arriving later, where it was first seen).
    if (!garment_.asleep()) bodies_.reset_references();
  }

  characters::GarmentInstance& garment() { return garment_; }
  BulletColliders& bodies() { return bodies_; }
  const BulletColliders& bodies() const { return bodies_; }

 private:
  characters::GarmentInstance& garment_;
  BulletColliders bodies_;
  BulletGarmentSettings settings_;
  std::string source_;
};

}  // namespace loom::bullet
