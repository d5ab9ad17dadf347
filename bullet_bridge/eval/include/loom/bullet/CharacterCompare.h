#pragma once
// `loom compare` on character scenes: the same character and garments run
//   - in Loom: the scene's own simulation (character stage, swept capsule contacts, self-collision), and
//   - in Bullet: each garment a classic btSoftBody (BulletTwin, tuned as in docs/bullet.md) in a
//     btSoftRigidDynamicsWorld together with the character's capsules as kinematic btRigidBody objects
//     driven by the clip (btMotionState at every frame end: Bullet takes kinematic poses once per
//     stepSimulation call), the garment's attached vertices anchored (appendAnchor) to the body
//     of their bone.
// Both are measured the same way after every frame: strain over every garment's structural springs, the
// deepest vertex inside a capsule and the number of vertices inside one, and the largest distance of an
// attached vertex from its bone target. Bullet-free and characters-free header: the caller (apps/loom)
// turns the scene's character into KinematicBody entries.
#include <functional>
#include <string>
#include <vector>

#include "loom/bullet/Compare.h"
#include "loom/cloth/Simulation.h"
#include "loom/collision/Collider.h"
#include "loom/collision/RigidBodySpec.h"

namespace loom::bullet {

struct KinematicBody {
  std::string name;
  collision::Shape shape;  // capsule (axis local y)
  bool collides = true;    // false: an anchor frame only (a joint with no capsule of its own)
  std::function<collision::Transform(double)> motion;  // pose at time t (s)
  std::vector<collision::BodyAttachment> attachments;  // garment vertices anchored to this body
  double friction = 0.3;                               // 1
};

struct CharacterCompareInput {
  cloth::SimulationSetup setup;  // the garments as cloths (attached vertices pinned), gravity, frame_dt
  std::vector<KinematicBody> bodies;
  int frames = 60;
  int bullet_substeps = 4;   // fixed Bullet steps per frame (1/240 s at 60 fps)
  double thickness = 0.001;  // m, the capsules' contact offset (Bullet: the soft body's margin)
  // Optional: called after every frame of run_bullet_character with every garment's vertices (m), in
  // setup.cloths order.
  std::function<void(int frame, const std::vector<const cloth::Vec3s*>& x)> on_frame;
};

struct CharacterMetrics {
  SystemMetrics m;                    // ms_per_frame, max_strain, mean_strain, max_penetration, diverged
  long penetrating_vertices = 0;      // largest number of vertices inside a capsule at a frame end
  double max_attachment_error = 0.0;  // m, attached vertex to its bone target at frame ends
};

// Loom: steps `sim` (the scene's simulation, built by scene::build_simulation) `in.frames` frames.
CharacterMetrics run_loom_character(cloth::Simulation& sim, const CharacterCompareInput& in);
// Bullet's classic soft body with kinematic capsules and anchors.
CharacterMetrics run_bullet_character(const CharacterCompareInput& in);

}  // namespace loom::bullet
