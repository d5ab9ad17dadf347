#pragma once
// ScenePipeline: what a scene runs, made by the one builder that every program running a scene uses
// (`loom run`, loom-view, the benchmarks). A scene without rigid `bodies` runs one cloth::Simulation with
// the stages of the effects it names (build_simulation, Build.h); a scene with `bodies` runs its cloths as
// one BulletCloth inside a Bullet world with those bodies (bullet::BulletScene), when the bridge is built,
// and a character's rig stage and capsule contact with them.
// Scene-level defaults are applied here, once, for every program alike (apply_scene_defaults).
#include <memory>

#include "loom/cloth/Simulation.h"
#include "loom/collision/Collider.h"
#include "loom/scene/Scene.h"
#ifdef LOOM_HAVE_BULLET
#include "loom/bullet/BulletScene.h"
#endif

namespace loom::bullet {
class BulletScene;
}  // namespace loom::bullet

namespace loom::scene {

// Defaults that depend on the scene as a whole: the guard's intersection check is on for a scene with exact
// self- or cloth-cloth collision unless the scene sets `guard.intersections` itself.
void apply_scene_defaults(Scene& scene);

class ScenePipeline {
 public:
  ~ScenePipeline();
  ScenePipeline(const ScenePipeline&) = delete;
  ScenePipeline& operator=(const ScenePipeline&) = delete;

  cloth::Simulation& simulation() { return *live_; }
  const cloth::Simulation& simulation() const { return *live_; }
  // One scene frame; in a Bullet world the bodies and the cloth step together.
  cloth::FrameStats step_frame();
  // The last step_frame() was abandoned on the simulation's stop flag (Simulation::set_stop_flag): the
  // frame is not a frame of the run. In a Bullet world the flag stops the cloth within the Bullet substep in
  // progress and the remaining substeps run no cloth step; the world is then mid-frame (not resumable).
  bool interrupted() const;
  // What to draw and census: the scene's colliders and a rig's capsules at their current poses, or the
  // rigid bodies at theirs (never null).
  const collision::ColliderSetPtr& colliders() const { return colliders_; }
  // The Bullet world of a scene with `bodies`, else null.
  bullet::BulletScene* bullet() { return bullet_.get(); }
  const bullet::BulletScene* bullet() const { return bullet_.get(); }
  // The scene as run, defaults applied.
  const Scene& scene() const { return scene_; }

 private:
  friend std::unique_ptr<ScenePipeline> build_pipeline(Scene scene);

#ifdef LOOM_HAVE_BULLET
  // The Bullet world options of a scene with `bodies`: its WorldTier (SceneQuality.h) as the bridge takes it.
  bullet::BulletSceneOptions bullet_scene_options(const Scene& scene);
#endif
  ScenePipeline() = default;

  Scene scene_;
  std::unique_ptr<cloth::Simulation> sim_;
  std::shared_ptr<bullet::BulletScene> bullet_;  // shared_ptr: complete only where the bridge is linked
  cloth::Simulation* live_ = nullptr;
  collision::ColliderSetPtr colliders_;
  collision::ColliderSetPtr capsules_;  // a character's capsules in a Bullet world (else null)
};

// Applies the scene defaults and builds what the scene runs. Throws loom::Error naming the scene file and
// the field for what cannot be combined (`bodies` with `colliders`, or `bodies` in a loom built without the
// Bullet bridge). A `character` with `bodies` runs its garments in the Bullet world, its rig's stage and
// capsule contact added to the BulletCloth's simulation.
std::unique_ptr<ScenePipeline> build_pipeline(Scene scene);

#ifdef LOOM_HAVE_BULLET
// The Bullet world options of a scene with `bodies`: its WorldTier (SceneQuality.h) as the bridge takes it.
bullet::BulletSceneOptions bullet_scene_options(const Scene& scene);
#endif

}  // namespace loom::scene
