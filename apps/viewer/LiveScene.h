#pragma once
// loom-view's simulation, without any GL (tested in tests/viewer without a display): the scene's
// pipeline built through scene::build_pipeline (as `loom run` builds it), effect toggles and material edits
// applied by rebuilding it from an edited copy of the scene while keeping the clock and every cloth's x, v,
// x_prev (solver history such as BDF2's previous step starts afresh), and dragging a cloth vertex picked with
// a ray (collision/RayCast.h) as a temporary kinematic pin. A scene with Bullet rigid `bodies` (only when
// built with the Bullet bridge, LOOM_HAVE_BULLET) runs in a bullet::BulletScene as `loom run` does:
// colliders() are then the bodies at their poses, picking goes through BulletCloth::ray_test
// (BulletScene::ray_test) and the grabbed vertex is a kinematic pin on the cloth simulation inside the Bullet
// world. The Bullet world's state is not copied, so there an edit (rebuild) starts the run again from the
// scene's start with the new settings.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "loom/cloth/Simulation.h"
#include "loom/collision/Collider.h"
#include "loom/scene/Scene.h"
#include "loom/scene/ScenePipeline.h"

namespace loom::bullet {
class BulletScene;
}

namespace loom::viewer {

// The effects a scene can have, as on/off switches (only those the scene names are offered).
struct Effects {
  bool drag = false;            // air drag and wind term
  bool strain_limit = false;    // constraints.strain_limit pass
  bool tethers = false;         // constraints.tethers pass
  bool colliders = false;       // the scene's colliders (body collision)
  bool self_collision = false;  // the `collision` object (self and cloth-cloth collision)
  bool character = false;       // a character rig and its capsules
};

struct Grab {
  int cloth = -1, vertex = -1;
  int triangle = -1;                              // the triangle the pick ray hit
  cloth::Vec3 barycentric = cloth::Vec3::Zero();  // 1, the hit point's weights on that triangle
  double distance = 0.0;                          // m from the ray origin to the grabbed point when picked
};

class LiveScene {
 public:
  // Throws loom::Error for a scene with `bodies` when built without the Bullet bridge, or one that also has
  // `colliders` or a character (as `loom run`).
  explicit LiveScene(scene::Scene scene);
  ~LiveScene();

  cloth::Simulation& sim() { return run_->simulation(); }
  const cloth::Simulation& sim() const { return run_->simulation(); }
  // The simulation's colliders (never null; empty without any).
  const collision::ColliderSet& colliders() const { return *run_->colliders(); }
  const scene::Scene& scene() const { return scene_; }
  // The Bullet world for a scene with `bodies`, else null.
  bullet::BulletScene* bullet() { return run_->bullet(); }
  const bullet::BulletScene* bullet() const { return run_->bullet(); }
  // Scene frames run and scene time (s) (in a Bullet scene sim() counts Bullet substeps).
  int frame() const;
  double time() const;

  const Effects& available() const { return available_; }  // what the scene names
  Effects& enabled() { return enabled_; }                  // edit, then rebuild()
  // Per-cloth materials, edit, then rebuild() (validated: an invalid edit throws and keeps the old run).
  std::vector<cloth::Material>& materials() { return materials_; }
  // Solver method and substeps for rebuild().
  std::string& solver() { return solver_; }
  int& substeps() { return substeps_; }

  // Rebuilds with the enabled effects, materials, solver and substeps; time and cloth states carry over.
  void rebuild();
  // Back to the scene's start with the current settings.
  void restart();
  // Steps one frame; a grabbed vertex moves to its target over the frame.
  cloth::FrameStats step_frame();

  // Picks the cloth vertex nearest to where the ray first hits a cloth; false when it hits none.
  bool grab(const cloth::Vec3& origin, const cloth::Vec3& dir);
  // Where the grabbed vertex should be at the end of the next frame (m).
  void drag_to(const cloth::Vec3& target) { target_ = target; }
  void release();
  const std::optional<Grab>& grabbed() const { return grab_; }
  const cloth::Vec3& target() const { return target_; }

 private:
  scene::Scene edited() const;
  void build(bool keep_state);
  bool hold(const Grab& g);  // makes the picked vertex a temporary kinematic pin (false for a pinned one)

  scene::Scene scene_;
  Effects available_, enabled_;
  std::vector<cloth::Material> materials_;
  std::string solver_;
  int substeps_ = 1;
  std::unique_ptr<scene::ScenePipeline> run_;
  std::optional<Grab> grab_;
  double grab_inv_mass_ = 0.0;  // the grabbed vertex's own inverse mass, restored on release
  cloth::Vec3 target_ = cloth::Vec3::Zero();
};

}  // namespace loom::viewer
