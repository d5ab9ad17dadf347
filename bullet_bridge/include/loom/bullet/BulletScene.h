#pragma once
// BulletScene: a scene's cloths and `bodies` (RigidBodySpec) in one btDiscreteDynamicsWorld, the cloths as
// one BulletCloth. `loom run` uses it for scenes with rigid bodies; the scene tests use it.
// Bullet-free header (pimpl): include it from code that links loom::bullet.
//
// One frame = world.stepSimulation(frame_dt, bullet_substeps + 1, frame_dt / bullet_substeps) after the
// kinematic bodies' motion state is set to their pose at the frame's end (BulletCloth interpolates them
// across the substeps). The cloth simulation inside runs with frame_dt = the Bullet substep.
#include <memory>
#include <string>
#include <vector>

#include "loom/bullet/ClothRay.h"
#include "loom/cloth/Simulation.h"
#include "loom/collision/Collider.h"
#include "loom/collision/RigidBodySpec.h"

namespace loom::bullet {

class BulletCloth;

struct BulletSceneOptions {
  int bullet_substeps = 4;  // Bullet fixed steps per scene frame (1/240 s at 60 fps)
  bool realtime = false;    // BulletClothSettings::Tier::realtime (the coupled solve) instead of setup
  // Tier::realtime only (0 or empty: BulletClothSettings' default). The setup's solver, substeps, strain
  // limit and tethers are not used there: the coupled solve has its own.
  std::string realtime_solver;   // pbd, xpbd or fast_xpbd
  int realtime_iterations = 0;   // solver iterations per cloth step
  int frame_steps = 0;           // cloth steps per scene frame (ceil over bullet_substeps: per substep)
  int coupling_iterations = 0;   // contact, tether and edge sweeps per cloth step
  double max_stretch = 0.0;      // 1, edge strain limit
  double tether_stretch = -1.0;  // 1, tether slack (< 0: the default)
};

// The tier a BulletScene runs: "coupled" (Tier::realtime) or "setup".
inline const char* tier_name(const BulletSceneOptions& o) { return o.realtime ? "coupled" : "setup"; }

class BulletScene {
 public:
  // setup.frame_dt is the scene's frame; setup.substeps (cloth steps per frame) is spread over the Bullet
  // substeps (at least one cloth step each). Throws loom::Error for bad input (unsupported body shape,
  // out-of-range attachment).
  BulletScene(const cloth::SimulationSetup& setup, const std::vector<collision::RigidBodySpec>& bodies,
              const BulletSceneOptions& options = {});
  ~BulletScene();
  BulletScene(const BulletScene&) = delete;
  BulletScene& operator=(const BulletScene&) = delete;

  // One scene frame. Returns the frame's statistics (energies and strain of the cloth state at its end,
  // stage times summed over the cloth steps, finite = every cloth step stayed finite).
  cloth::FrameStats step_frame();
  // The last step_frame() met the simulation's stop flag (Simulation::set_stop_flag): the cloth stopped
  // within a Bullet substep (back to that substep's start) and ran no later substep, so the frame is
  // incomplete and the world is left mid-frame.
  bool interrupted() const { return interrupted_; }
  int frame() const { return frame_; }
  double time() const;                           // s
  double frame_dt() const { return frame_dt_; }  // s
  int bullet_substeps() const { return substeps_; }
  const BulletSceneOptions& options() const { return options_; }
  long cloth_steps() const;  // cloth pipeline steps run so far (adaptive: BulletClothSettings)
  // The fewest cloth steps a frame runs: bullet_substeps x BulletCloth::min_cloth_steps (a frame runs more
  // where a body moves near the cloth).
  int min_cloth_steps_per_frame() const;

  cloth::Simulation& simulation();
  const cloth::Simulation& simulation() const;
  BulletCloth& cloth() { return *cloth_; }
  // BulletCloth::ray_test for code that does not include Bullet headers (loom-view's picking): the nearest
  // cloth triangle hit by the segment from -> to (m), `cloth` set to the cloth's index in simulation().
  RayHit ray_test(const Vec3& from, const Vec3& to) const;

  // One collider per body (its shape, `curr` = its pose now), refreshed after every frame; names are the
  // bodies' names. The renderer draws these.
  const collision::ColliderSetPtr& body_colliders() const { return body_colliders_; }
  size_t num_bodies() const;
  collision::Vec3 body_position(size_t k) const;  // m, centre of mass
  collision::Vec3 body_velocity(size_t k) const;  // m/s
  // Deepest cloth vertex inside any body now (m, >= 0; exact signed distance to the body's shape).
  double max_penetration() const;
  // Unsupported shapes BulletCloth met (each once).
  const std::vector<std::string>& warnings() const;

 private:
  struct World;
  void refresh_colliders();

  std::vector<collision::RigidBodySpec> specs_;
  BulletSceneOptions options_;
  std::unique_ptr<World> world_;
  std::unique_ptr<BulletCloth> cloth_;
  collision::ColliderSetPtr body_colliders_;
  double frame_dt_ = 0.0;
  int substeps_ = 4;
  int frame_ = 0;
  bool interrupted_ = false;
};

}  // namespace loom::bullet
