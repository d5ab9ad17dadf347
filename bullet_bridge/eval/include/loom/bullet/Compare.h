#pragma once
// Side-by-side runs for `loom compare`: one scene's cloth (and rigid bodies) run as a Loom cloth in
// a Bullet world (BulletCloth, two-way coupled), as Bullet's classic btSoftBody (BulletTwin, tuned as in
// docs/bullet.md: piterations 10, 1/240 s steps, margin = cloth thickness, kKHR 1, SDF voxel 0.05 m)
// and, when the scene has no rigid bodies, as a deformable-world body. Bullet-free header.
#include <functional>
#include <string>
#include <vector>

#include "loom/bullet/BulletScene.h"
#include "loom/bullet/BulletTwin.h"
#include "loom/cloth/Simulation.h"
#include "loom/collision/RigidBodySpec.h"

namespace loom::bullet {

// One frame's end: cloth 0's vertices and the bodies' centres of mass (m, in `bodies` order).
struct FrameSample {
  int frame = 0;
  const cloth::Vec3s* x = nullptr;
  std::vector<cloth::Vec3> centres;
};

struct CompareInput {
  cloth::SimulationSetup setup;  // cloth 0 is compared; frame_dt = the scene's frame
  std::vector<collision::RigidBodySpec> bodies;
  int frames = 60;
  int bullet_substeps = 4;  // Bullet fixed steps per frame (frame_dt / 4 = 1/240 s at 60 fps)
  // Loom's tier in the world (BulletScene.h; a scene's: scene::bullet_scene_options); its bullet_substeps
  // is replaced by the one above.
  BulletSceneOptions options;
  // Optional: run on the simulation before the first frame (Loom) or before the twin copies cloth 0's
  // start state (e.g. a perturbation of x; set x_prev too).
  std::function<void(cloth::Simulation&)> prepare;
  // Optional: called with the start state (frame 0), then after every frame.
  std::function<void(const FrameSample&)> on_frame;
};

struct SystemMetrics {
  std::string system;     // "loom", "bullet_classic", "bullet_deformable"
  std::string tier;       // loom: the bridge's tier, "coupled" or "setup" (tier_name)
  bool available = true;  // false: not run (see note)
  std::string note;
  double ms_per_frame = 0.0;     // ms, wall time per frame (cloth + world)
  double max_strain = 0.0;       // 1, largest stretch l/L - 1 over structural springs, over all frames
  double mean_strain = 0.0;      // 1, mean over frames of the mean |l/L - 1| over structural springs
  double max_penetration = 0.0;  // m, deepest cloth vertex inside a rigid body, over all frames
  // Non-finite positions, max strain > 10, Bullet switched the body off, or (loom) the frame `loom run`
  // stops at: the guard failed it (energy explosion, strain, ...) or a body became non-finite.
  bool diverged = false;
  // Why `diverged`, with the frame ("" when not diverged): for Loom the cause `loom run` reports (the
  // guard's), else the first non-finite vertex, a strain past 10, or a twin that stopped simulating.
  std::string diverged_why;
  std::vector<double> final_positions;  // m, cloth 0's vertex coordinates at the end (x0 y0 z0 x1 ...)
};

SystemMetrics run_loom_in_bullet(const CompareInput& in);
SystemMetrics run_bullet_twin(const CompareInput& in, TwinKind kind);

}  // namespace loom::bullet
