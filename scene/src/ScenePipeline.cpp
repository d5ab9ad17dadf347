#include "loom/scene/ScenePipeline.h"

#include "loom/cloth/Error.h"
#include "loom/collision/RealtimeBodyContact.h"
#include "loom/collision/SelfCollisionStage.h"
#include "loom/scene/Build.h"

#ifdef LOOM_HAVE_BULLET
#include "loom/bullet/BulletScene.h"
#endif
#ifdef LOOM_HAVE_CHARACTERS
#include "loom/characters/Character.h"
#endif

namespace loom::scene {

namespace {

bool cloth_collision(const Scene& s) {
  return s.collision && (s.collision->self || s.setup.cloths.size() > 1);
}

}  // namespace

#ifdef LOOM_HAVE_BULLET
bullet::BulletSceneOptions bullet_scene_options(const Scene& scene) {
  bullet::BulletSceneOptions o;
  const WorldTier& w = scene.world;
  o.realtime = w.coupled;
  o.realtime_solver = w.solver;
  o.realtime_iterations = w.iterations;
  o.frame_steps = w.substeps;
  o.coupling_iterations = w.coupling_iterations;
  o.max_stretch = w.max_stretch;
  o.tether_stretch = w.tether_stretch;
  return o;
}
#endif

void apply_scene_defaults(Scene& scene) {
  // Exact cloth-cloth collision gets the guard's per-step intersection check; the tiers' proximity collision
  // samples its checks instead (`loom run --census`).
  if (!scene.setup.guard.intersections_set && cloth_collision(scene) && !scene.proximity)
    scene.setup.guard.intersections = true;
}

ScenePipeline::~ScenePipeline() = default;

cloth::FrameStats ScenePipeline::step_frame() {
#ifdef LOOM_HAVE_BULLET
  if (bullet_) {
    cloth::FrameStats stats = bullet_->step_frame();
    if (capsules_) {  // what is drawn: the bodies, then the character's capsules, at their poses now
      *colliders_ = *bullet_->body_colliders();
      colliders_->insert(colliders_->end(), capsules_->begin(), capsules_->end());
    }
    return stats;
  }
#endif
  return sim_->step_frame();
}

bool ScenePipeline::interrupted() const {
#ifdef LOOM_HAVE_BULLET
  if (bullet_) return bullet_->interrupted();
#endif
  return live_->interrupted();
}

std::unique_ptr<ScenePipeline> build_pipeline(Scene scene) {
  apply_scene_defaults(scene);
  std::unique_ptr<ScenePipeline> p(new ScenePipeline());
  if (scene.bodies.empty()) {
    p->sim_ = build_simulation(scene, &p->colliders_);
    p->live_ = p->sim_.get();
    p->scene_ = std::move(scene);
    return p;
  }
#ifdef LOOM_HAVE_BULLET
  if (!scene.colliders.empty())
    throw Error(scene.file, "colliders",
                "cannot be combined with 'bodies': give static shapes as bodies (mass 0)");
  // The cloths as one BulletCloth in a Bullet world with the bodies; cloth-cloth collision as in
  // build_simulation. The colliders drawn and censused are the bodies at their poses.
  p->bullet_ = std::make_shared<bullet::BulletScene>(scene.setup, scene.bodies, bullet_scene_options(scene));
  p->colliders_ = p->bullet_->body_colliders();
#ifdef LOOM_HAVE_CHARACTERS
  if (scene.character) {
    // A character in the world: its stage moves the attached garment vertices and its capsules (a set of
    // their own, kinematic for the cloth, unseen by the bodies), and the real-time contact against the
    // capsules runs after the bodies' contacts. Drawn: the bodies, then the capsules.
    p->capsules_ = std::make_shared<collision::ColliderSet>();
    characters::add_character(p->bullet_->simulation(), scene.character, p->capsules_);
    p->bullet_->simulation().add_stage(std::make_unique<collision::RealtimeBodyContactStage>(p->capsules_));
    p->colliders_ = std::make_shared<collision::ColliderSet>(*p->bullet_->body_colliders());
    p->colliders_->insert(p->colliders_->end(), p->capsules_->begin(), p->capsules_->end());
  }
#endif
  if (cloth_collision(scene))
    p->bullet_->simulation().add_stage(std::make_unique<collision::SelfCollisionStage>(*scene.collision));
  p->live_ = &p->bullet_->simulation();
  p->scene_ = std::move(scene);
  return p;
#else
  throw Error(
      scene.file, "bodies",
      "rigid bodies need the Bullet bridge, and this loom was built without it (Debian: libbullet-dev)");
#endif
}

}  // namespace loom::scene
