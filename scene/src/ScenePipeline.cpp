#include "loom/scene/ScenePipeline.h"

#include "loom/cloth/Error.h"
#include "loom/collision/SelfCollisionStage.h"
#include "loom/scene/Build.h"

#ifdef LOOM_HAVE_BULLET
#include "loom/bullet/BulletScene.h"
#endif

namespace loom::scene {

namespace {

bool cloth_collision(const Scene& s) {
  return s.collision && (s.collision->self || s.setup.cloths.size() > 1);
}

}  // namespace

void apply_scene_defaults(Scene& scene) {
  if (!scene.setup.guard.intersections_set && cloth_collision(scene)) scene.setup.guard.intersections = true;
}

ScenePipeline::~ScenePipeline() = default;

cloth::FrameStats ScenePipeline::step_frame() {
#ifdef LOOM_HAVE_BULLET
  if (bullet_) return bullet_->step_frame();
#endif
  return sim_->step_frame();
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
  if (scene.character) throw Error(scene.file, "character", "cannot be combined with 'bodies'");
  // The cloths as one BulletCloth in a Bullet world with the bodies; cloth-cloth collision as in
  // build_simulation. The colliders drawn and censused are the bodies at their poses.
  p->bullet_ = std::make_shared<bullet::BulletScene>(scene.setup, scene.bodies);
  if (cloth_collision(scene))
    p->bullet_->simulation().add_stage(std::make_unique<collision::SelfCollisionStage>(*scene.collision));
  p->live_ = &p->bullet_->simulation();
  p->colliders_ = p->bullet_->body_colliders();
  p->scene_ = std::move(scene);
  return p;
#else
  throw Error(
      scene.file, "bodies",
      "rigid bodies need the Bullet bridge, and this loom was built without it (Debian: libbullet-dev)");
#endif
}

}  // namespace loom::scene
