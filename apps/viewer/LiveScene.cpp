#include "LiveScene.h"

#include <algorithm>
#include <cmath>

#include "loom/cloth/Error.h"
#include "loom/collision/RayCast.h"
#ifdef LOOM_HAVE_BULLET
#include "loom/bullet/BulletScene.h"
#endif

namespace loom::viewer {

LiveScene::LiveScene(scene::Scene scene) : scene_(std::move(scene)) {
  available_.drag = scene_.setup.drag.has_value() || scene_.setup.wind.has_value();
  available_.strain_limit = scene_.setup.strain_limit.has_value();
  available_.tethers = scene_.setup.tethers.has_value();
  available_.colliders = !scene_.colliders.empty();
  available_.self_collision = scene_.collision.has_value();
  available_.character = scene_.character != nullptr;
  enabled_ = available_;
  for (const cloth::ClothSetup& c : scene_.setup.cloths) materials_.push_back(c.material);
  solver_ = scene_.setup.solver.method;
  substeps_ = scene_.setup.substeps;
  build(false);  // throws what scene::build_pipeline refuses
}

LiveScene::~LiveScene() = default;

int LiveScene::frame() const {
#ifdef LOOM_HAVE_BULLET
  if (bullet()) return bullet()->frame();
#endif
  return sim().frame();
}

double LiveScene::time() const {
#ifdef LOOM_HAVE_BULLET
  if (bullet()) return bullet()->time();
#endif
  return sim().time();
}

scene::Scene LiveScene::edited() const {
  scene::Scene s = scene_;
  if (!enabled_.drag) {
    s.setup.drag.reset();
    s.setup.wind.reset();
  }
  if (!enabled_.strain_limit) s.setup.strain_limit.reset();
  if (!enabled_.tethers) s.setup.tethers.reset();
  if (!enabled_.colliders) s.colliders.clear();
  if (!enabled_.self_collision) s.collision.reset();
  if (!enabled_.character) s.character.reset();
  for (size_t c = 0; c < s.setup.cloths.size(); ++c) s.setup.cloths[c].material = materials_[c];
  s.setup.solver.method = solver_;
  s.setup.substeps = substeps_;
  return s;
}

void LiveScene::build(bool keep_state) {
  std::unique_ptr<scene::ScenePipeline> fresh = scene::build_pipeline(edited());  // throws: old run kept
  if (fresh->bullet()) {
    // The Bullet world's state is not copied: this starts from the scene's start (the grab goes with the
    // old cloth).
    grab_.reset();
    run_ = std::move(fresh);
    return;
  }
  if (keep_state && run_ && !run_->bullet()) {
    const cloth::Simulation& old = run_->simulation();
    cloth::Simulation& sim = fresh->simulation();
    for (size_t c = 0; c < sim.cloths().size(); ++c) {
      const cloth::ClothState& from = old.cloths()[c]->state();
      cloth::ClothState& to = sim.cloths()[c]->state();
      to.x = from.x;
      to.v = from.v;
      to.x_prev = from.x_prev;
    }
    sim.set_frame(old.frame());
    // Colliders continue from their current poses (scene motion resamples them each step anyway).
    const collision::ColliderSetPtr& now = fresh->colliders();
    const collision::ColliderSetPtr& before = run_->colliders();
    for (size_t k = 0; k < now->size() && k < before->size(); ++k)
      if ((*now)[k].name == (*before)[k].name) {
        (*now)[k].prev = (*before)[k].prev;
        (*now)[k].curr = (*before)[k].curr;
      }
  }
  run_ = std::move(fresh);
  if (grab_) {  // the new cloth has its own inverse masses: keep the grabbed vertex kinematic
    cloth::ClothState& s = sim().cloths()[grab_->cloth]->state();
    grab_inv_mass_ = s.inv_mass[grab_->vertex];
    s.inv_mass[grab_->vertex] = 0.0;
  }
}

void LiveScene::rebuild() { build(true); }

void LiveScene::restart() {
  grab_.reset();
  build(false);
}

cloth::FrameStats LiveScene::step_frame() {
  if (grab_) {
    // Kinematic for this frame (Solver.h contract): every substep moves it by h v, so it ends at the target.
    cloth::ClothState& s = sim().cloths()[grab_->cloth]->state();
    // In a Bullet scene the cloth steps Bullet substeps inside one scene frame of bullet()->frame_dt().
    double dt = sim().setup().frame_dt;
#ifdef LOOM_HAVE_BULLET
    if (bullet()) dt = bullet()->frame_dt();
#endif
    s.v[grab_->vertex] = (target_ - s.x[grab_->vertex]) / dt;
  }
  cloth::FrameStats stats = run_->step_frame();
  if (grab_) sim().cloths()[grab_->cloth]->state().v[grab_->vertex].setZero();
  return stats;
}

bool LiveScene::grab(const cloth::Vec3& origin, const cloth::Vec3& dir) {
  release();
  Grab g;
#ifdef LOOM_HAVE_BULLET
  if (bullet()) {
    // BulletCloth::ray_test casts a segment: from the origin to past the farthest cloth vertex.
    const double len = dir.norm();
    if (!(len > 0.0)) return false;
    double reach = 0.0;
    for (const auto& c : sim().cloths())
      for (const cloth::Vec3& p : c->state().x) reach = std::max(reach, (p - origin).norm());
    const bullet::RayHit hit = bullet()->ray_test(origin, origin + (2.0 * reach + 1.0) / len * dir);
    if (!hit.hit) return false;
    int k = 0;
    hit.barycentric.maxCoeff(&k);
    g.cloth = hit.cloth;
    g.triangle = hit.triangle;
    g.barycentric = hit.barycentric;
    g.vertex = sim().cloths()[hit.cloth]->mesh().triangles()[hit.triangle][k];
    g.distance = hit.distance;
    return hold(g);
  }
#endif
  std::optional<collision::RayHit> best;
  int best_cloth = -1;
  for (size_t c = 0; c < sim().cloths().size(); ++c) {
    const cloth::Cloth& cl = *sim().cloths()[c];
    const auto hit = collision::ray_cast(origin, dir, cl.state().x, cl.mesh().triangles());
    if (hit && (!best || hit->distance < best->distance)) {
      best = hit;
      best_cloth = static_cast<int>(c);
    }
  }
  if (!best) return false;
  const cloth::Cloth& cl = *sim().cloths()[best_cloth];
  g.cloth = best_cloth;
  g.triangle = best->triangle;
  g.barycentric = best->barycentric;
  g.vertex = collision::nearest_corner(*best, cl.mesh().triangles());
  g.distance = best->distance;
  return hold(g);
}

bool LiveScene::hold(const Grab& g) {
  cloth::ClothState& s = sim().cloths()[g.cloth]->state();
  // A pinned vertex stays as it is (its pin owns it).
  if (s.inv_mass[g.vertex] == 0.0) return false;
  grab_ = g;
  grab_inv_mass_ = s.inv_mass[g.vertex];
  s.inv_mass[g.vertex] = 0.0;
  target_ = s.x[g.vertex];
  return true;
}

void LiveScene::release() {
  if (!grab_) return;
  sim().cloths()[grab_->cloth]->state().inv_mass[grab_->vertex] = grab_inv_mass_;
  grab_.reset();
}

}  // namespace loom::viewer
