#include "loom/bullet/BulletScene.h"

#include <btBulletDynamicsCommon.h>

#include <algorithm>

#include "BulletConvert.h"
#include "ShapeDistance.h"
#include "loom/bullet/BulletCloth.h"
#include "loom/bullet/RigidBodies.h"
#include "loom/cloth/Error.h"

namespace loom::bullet {

using collision::RigidBodySpec;

// The Bullet world and the scene's rigid bodies (in `bodies` order). Members are destroyed in reverse order:
// the bodies leave the world before the world goes.
struct BulletScene::World {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  RigidBodies rigid{world};
  std::vector<std::unique_ptr<btRigidBody>>& bodies = rigid.bodies;

  void add(const RigidBodySpec& b, size_t index) { rigid.add(b, index); }
};

namespace {

// fixed_dt = frame_dt / bullet_substeps; Tier::setup spreads setup.substeps over the Bullet substeps;
// Tier::realtime takes the options' coupled-solve values over BulletClothSettings' defaults.
BulletClothSettings scene_cloth_settings(const cloth::SimulationSetup& setup, const BulletSceneOptions& o) {
  if (o.bullet_substeps < 1) throw Error("", "bullet_substeps", "must be >= 1");
  auto per_substep = [&](int per_frame) {
    return std::max(1, (per_frame + o.bullet_substeps - 1) / o.bullet_substeps);
  };
  BulletClothSettings s;
  s.fixed_dt = setup.frame_dt / o.bullet_substeps;
  if (!o.realtime) {
    s.tier = BulletClothSettings::Tier::setup;
    s.cloth_substeps = per_substep(setup.substeps);
    return s;
  }
  s.tier = BulletClothSettings::Tier::realtime;
  s.cloth_substeps = 1;  // the coupled solve's own steps (realtime_substeps), not the setup's
  if (!o.realtime_solver.empty()) s.realtime_solver = o.realtime_solver;
  if (o.realtime_iterations > 0) s.realtime_iterations = o.realtime_iterations;
  if (o.frame_steps > 0) s.realtime_substeps = per_substep(o.frame_steps);
  if (o.coupling_iterations > 0) s.coupling_iterations = o.coupling_iterations;
  if (o.max_stretch > 0.0) s.max_stretch = o.max_stretch;
  if (o.tether_stretch >= 0.0) s.tether_stretch = o.tether_stretch;
  return s;
}

}  // namespace

BulletScene::BulletScene(const cloth::SimulationSetup& setup, const std::vector<RigidBodySpec>& bodies,
                         const BulletSceneOptions& options)
    : specs_(bodies),
      options_(options),
      world_(std::make_unique<World>()),
      body_colliders_(std::make_shared<collision::ColliderSet>()) {
  if (options.bullet_substeps < 1) throw Error("", "bullet_substeps", "must be >= 1");
  frame_dt_ = setup.frame_dt;
  substeps_ = options.bullet_substeps;
  world_->world.setGravity(to_bt(setup.gravity));
  for (size_t k = 0; k < specs_.size(); ++k) world_->add(specs_[k], k);
  cloth_ = std::make_unique<BulletCloth>(setup, scene_cloth_settings(setup, options));
  const int num_cloths = static_cast<int>(cloth_->simulation().cloths().size());
  for (size_t k = 0; k < specs_.size(); ++k)
    for (size_t a = 0; a < specs_[k].attachments.size(); ++a) {
      const collision::BodyAttachment& at = specs_[k].attachments[a];
      const std::string field = "bodies[" + std::to_string(k) + "].attach[" + std::to_string(a) + "]";
      if (at.cloth < 0 || at.cloth >= num_cloths)
        throw Error("", field + ".cloth", "no cloth with this index");
      if (at.vertex < 0 || at.vertex >= cloth_->simulation().cloths()[at.cloth]->state().size())
        throw Error("", field + ".vertex", "out of range");
      cloth_->attach(at.cloth, at.vertex, world_->bodies[k].get());
    }
  cloth_->add_to(&world_->world);
  for (const RigidBodySpec& b : specs_) {
    collision::Collider c;
    c.name = b.name;
    c.shape = b.shape;
    body_colliders_->push_back(std::move(c));
  }
  refresh_colliders();
}

BulletScene::~BulletScene() {
  if (cloth_) cloth_->remove_from(&world_->world);
}

cloth::Simulation& BulletScene::simulation() { return cloth_->simulation(); }
const cloth::Simulation& BulletScene::simulation() const { return cloth_->simulation(); }
double BulletScene::time() const { return frame_ * frame_dt_; }
long BulletScene::cloth_steps() const { return cloth_->cloth_steps(); }
int BulletScene::min_cloth_steps_per_frame() const { return substeps_ * cloth_->min_cloth_steps(); }
size_t BulletScene::num_bodies() const { return world_->bodies.size(); }
Vec3 BulletScene::body_position(size_t k) const {
  return to_eigen(world_->bodies.at(k)->getCenterOfMassPosition());
}
Vec3 BulletScene::body_velocity(size_t k) const {
  return to_eigen(world_->bodies.at(k)->getLinearVelocity());
}
const std::vector<std::string>& BulletScene::warnings() const { return cloth_->warnings(); }
RayHit BulletScene::ray_test(const Vec3& from, const Vec3& to) const { return cloth_->ray_test(from, to); }

void BulletScene::refresh_colliders() {
  for (size_t k = 0; k < world_->bodies.size(); ++k) {
    collision::Collider& c = (*body_colliders_)[k];
    c.prev = c.curr;
    c.curr = to_eigen(world_->bodies[k]->getWorldTransform());
    if (frame_ == 0) c.prev = c.curr;
  }
}

cloth::FrameStats BulletScene::step_frame() {
  const double t_end = (frame_ + 1) * frame_dt_;
  for (size_t k = 0; k < specs_.size(); ++k)
    if (specs_[k].motion)
      world_->bodies[k]->getMotionState()->setWorldTransform(to_bt(specs_[k].motion(t_end)));
  simulation().set_output_frame(frame_ + 1, frame_dt_);  // a failure names this output frame, not the substep
  const long before = cloth_->substeps();
  std::vector<double> stage_ms;
  double total_ms = 0.0;
  bool finite = true;
  // Bullet calls the cloth once per substep; sum what each cloth step reported.
  struct Tap final : btActionInterface {
    BulletCloth* cloth = nullptr;
    std::vector<double>* stage_ms = nullptr;
    double* total_ms = nullptr;
    bool* finite = nullptr;
    void updateAction(btCollisionWorld*, btScalar) override {
      const cloth::FrameStats& s = cloth->last_stats();
      if (stage_ms->size() < s.stage_ms.size()) stage_ms->resize(s.stage_ms.size(), 0.0);
      for (size_t k = 0; k < s.stage_ms.size(); ++k) (*stage_ms)[k] += s.stage_ms[k];
      *total_ms += s.total_ms;
      *finite = *finite && s.finite;
    }
    void debugDraw(btIDebugDraw*) override {}
  } tap;
  tap.cloth = cloth_.get();
  tap.stage_ms = &stage_ms;
  tap.total_ms = &total_ms;
  tap.finite = &finite;
  world_->world.addAction(&tap);  // after the cloth: actions run in the order added
  world_->world.stepSimulation(btScalar(frame_dt_), substeps_ + 1, btScalar(frame_dt_ / substeps_));
  world_->world.removeAction(&tap);
  interrupted_ = simulation().stop_requested();
  ++frame_;
  cloth::FrameStats out = cloth_->substeps() > before ? cloth_->last_stats() : simulation().measure();
  out.frame = frame_;
  out.time = time();
  out.stage_ms = stage_ms;
  out.stage_ms.resize(simulation().stage_names().size(), 0.0);
  out.total_ms = total_ms;
  out.finite = finite && out.finite;
  refresh_colliders();
  return out;
}

double BulletScene::max_penetration() const {
  double worst = 0.0;
  for (size_t k = 0; k < world_->bodies.size(); ++k) {
    const collision::Transform pose = to_eigen(world_->bodies[k]->getWorldTransform());
    for (const auto& c : cloth_->simulation().cloths())
      for (const Vec3& p : c->state().x)
        worst = std::max(worst, -shape_signed_distance(specs_[k].shape, nullptr, pose, p, nullptr));
  }
  return worst;
}

}  // namespace loom::bullet
