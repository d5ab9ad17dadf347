#include "loom/bullet/BulletCloth.h"

#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <cmath>

#include "BodyCoupling.h"
#include "BulletConvert.h"
#include "loom/cloth/Error.h"
#include "loom/collision/BodyCollisionStage.h"
#include "loom/collision/ColliderGeometry.h"
#include "loom/collision/FeatureContact.h"

namespace loom::bullet {

using collision::Collider;
using collision::Transform;

namespace {

// The cloth's broad-phase citizen: a user-type collision object (docs/bullet.md, CO_USER_TYPE).
class ClothObject final : public btCollisionObject {
 public:
  explicit ClothObject(BulletCloth* owner) {
    m_internalType = CO_USER_TYPE;
    setUserPointer(owner);
  }
};

// Radius (m) of a ball around the shape's own origin holding it (0 for planes).
double shape_radius(const collision::Shape& s) {
  using collision::ShapeType;
  double r = 0.0;
  switch (s.type) {
    case ShapeType::plane:
      return 0.0;
    case ShapeType::sphere:
      return s.radius;
    case ShapeType::capsule:
      return s.radius + s.half_height;
    case ShapeType::box:
      return s.half_extents.norm();
    case ShapeType::cylinder:
      return std::hypot(s.radius, s.half_height);
    case ShapeType::convex:
    case ShapeType::mesh:
      for (const Vec3& v : s.vertices) r = std::max(r, v.norm());
      return r;
  }
  return r;
}

// Radius (m) of a ball around the body origin holding the collider (0 for planes: static or moving flat).
double reach_from_origin(const Collider& c) {
  if (c.shape.type == collision::ShapeType::plane) return 0.0;
  return shape_radius(c.shape) + c.curr.translation().norm();
}

// A lower bound (m) of the distance from the box [lo, hi] to the collider `c` (body frame) on a body at
// `body`: a plane's least signed distance over the box's corners (negative below it); otherwise the
// distance from the shape's bounding ball.
double distance_bound(const Collider& c, const Transform& body, const Vec3& lo, const Vec3& hi) {
  const Transform pose = body * c.curr;
  if (c.shape.type == collision::ShapeType::plane) {
    const Vec3 n = pose.linear().col(1);  // the plane's local +y
    const Vec3 corner(n.x() < 0 ? hi.x() : lo.x(), n.y() < 0 ? hi.y() : lo.y(), n.z() < 0 ? hi.z() : lo.z());
    return n.dot(corner - pose.translation());
  }
  const Vec3 p = pose.translation();
  return (p - p.cwiseMax(lo).cwiseMin(hi)).norm() - shape_radius(c.shape);
}

Transform slerp(const Transform& a, const Transform& b, double f) {
  Transform out = Transform::Identity();
  const Eigen::Quaterniond qa(a.linear()), qb(b.linear());
  out.linear() = qa.slerp(f, qb).toRotationMatrix();
  out.translation() = (1.0 - f) * a.translation() + f * b.translation();
  return out;
}

}  // namespace

// Where a body is during the current Bullet substep: `start` at its beginning, `end` at its end.
struct BulletCloth::BodyTrack {
  Transform start = Transform::Identity(), end = Transform::Identity();
  // Kinematic bodies: Bullet holds the pose that saveKinematicState read for the whole stepSimulation call;
  // we move from `from` to `target` over `span` seconds instead (constant velocity, as Bullet's own
  // velocity).
  bool initialised = false;
  Transform from = Transform::Identity(), target = Transform::Identity();
  double tau = 0.0, span = 0.0;  // s
  long seen = -2;                // the Bullet substep (BulletCloth::substeps_) it was last tracked in
  Vec3 applied = Vec3::Zero();   // N s, summed impulse applied to the body
  Vec3 step_impulse = Vec3::Zero(), step_moment = Vec3::Zero();  // this substep's reaction (about the COM)
  std::vector<Collider> local;                                   // the shape's colliders in the body frame
  const btCollisionShape* local_of = nullptr;
  Transform at(double f) const { return slerp(start, end, std::clamp(f, 0.0, 1.0)); }
};

// before_solve: collider poses for this cloth step, interpolated inside the Bullet substep.
class BulletCloth::PoseStage final : public cloth::Stage {
 public:
  explicit PoseStage(BulletCloth& owner) : o_(owner) {}
  const char* name() const override { return "bullet_poses"; }
  void run(cloth::StageContext& ctx) override {
    const double dt = o_.settings_.fixed_dt;
    const double f0 = (ctx.t - o_.substep_t0_) / dt, f1 = (ctx.t + ctx.h - o_.substep_t0_) / dt;
    collision::ColliderSet& cs = *o_.colliders_;
    for (size_t k = 0; k < cs.size(); ++k) {
      const BodyTrack* tr = o_.tracks_.at(o_.collider_body_[k]).get();
      const Vec3 old_origin = cs[k].curr.translation();
      cs[k].prev = tr->at(f0) * o_.collider_local_[k];
      cs[k].curr = tr->at(f1) * o_.collider_local_[k];
      // Keep the summed moment about the (moving) curr origin: L_b = L_a + (a - b) x J.
      cs[k].reaction_angular_impulse += (old_origin - cs[k].curr.translation()).cross(cs[k].reaction_impulse);
    }
  }

 private:
  BulletCloth& o_;
};

// before_solve: attached vertices are kinematic; their velocity takes them to the body point at t + h.
class BulletCloth::AttachStage final : public cloth::Stage {
 public:
  explicit AttachStage(BulletCloth& owner) : o_(owner) {}
  const char* name() const override { return "bullet_attachments"; }
  void run(cloth::StageContext& ctx) override {
    const double f1 = (ctx.t + ctx.h - o_.substep_t0_) / o_.settings_.fixed_dt;
    v_old.resize(o_.attachments_.size());
    for (size_t a = 0; a < o_.attachments_.size(); ++a) {
      const Attachment& at = o_.attachments_[a];
      cloth::ClothState& s = ctx.cloths[at.cloth]->state();
      v_old[a] = s.v[at.vertex];
      const Vec3 target = o_.tracks_.at(at.body)->at(f1) * at.offset;
      s.v[at.vertex] = (target - s.x[at.vertex]) / ctx.h;
    }
  }
  std::vector<Vec3> v_old;  // m/s, attached vertices' velocities at the step's start

 private:
  BulletCloth& o_;
};

// after_solve: the force each attached vertex exerts on its body over the step, J = h f_i - m_i dv_i
// (f_i: all the cloth's forces on the vertex at the step's end; Newton: m dv = h (f_i + F_body)).
class BulletCloth::ReactionStage final : public cloth::Stage {
 public:
  ReactionStage(BulletCloth& owner, AttachStage& attach) : o_(owner), attach_(attach) {}
  const char* name() const override { return "bullet_attachment_reaction"; }
  void run(cloth::StageContext& ctx) override {
    const double f1 = (ctx.t + ctx.h - o_.substep_t0_) / o_.settings_.fixed_dt;
    for (size_t c = 0; c < ctx.cloths.size(); ++c) {
      bool any = false;
      for (const Attachment& at : o_.attachments_)
        any |= at.cloth == static_cast<int>(c) && !at.body->isStaticOrKinematicObject();
      if (!any) continue;
      cloth::Cloth& cl = *ctx.cloths[c];
      cloth::ClothState& s = cl.state();
      f_.assign(s.size(), Vec3::Zero());
      cl.compute_forces(s.x, s.v, ctx.t + ctx.h, ctx.threads, f_);
      for (size_t a = 0; a < o_.attachments_.size(); ++a) {
        const Attachment& at = o_.attachments_[a];
        if (at.cloth != static_cast<int>(c) || at.body->isStaticOrKinematicObject()) continue;
        const Vec3 j = ctx.h * f_[at.vertex] - s.mass[at.vertex] * (s.v[at.vertex] - attach_.v_old[a]);
        BodyTrack& tr = *o_.tracks_.at(at.body);
        tr.step_impulse += j;
        tr.step_moment += (s.x[at.vertex] - tr.at(f1).translation()).cross(j);
      }
    }
  }

 private:
  BulletCloth& o_;
  AttachStage& attach_;
  cloth::Vec3s f_;
};

BulletCloth::BulletCloth(cloth::SimulationSetup setup, const BulletClothSettings& settings)
    : settings_(settings), colliders_(std::make_shared<collision::ColliderSet>()) {
  if (!(settings.fixed_dt > 0.0)) throw Error("", "bullet.fixed_dt", "must be > 0");
  if (settings.cloth_substeps < 1) throw Error("", "bullet.cloth_substeps", "must be >= 1");
  if (settings.max_cloth_substeps > 4096) throw Error("", "bullet.max_cloth_substeps", "must be <= 4096");
  if (!(settings.thickness >= 0.0)) throw Error("", "bullet.thickness", "must be >= 0");
  if (!(settings.step_motion > 0.0)) throw Error("", "bullet.step_motion", "must be > 0");
  double thickness = settings.thickness;
  for (const cloth::ClothSetup& c : setup.cloths) thickness = std::max(thickness, c.material.thickness);
  // setup.substeps 0 (the API's default): the solver's own step (Solver.h, default_substeps) when it is
  // shorter than the Bullet step divided by cloth_substeps.
  const int solver_steps =
      setup.substeps == 0 ? cloth::default_substeps(setup.solver.method, settings.fixed_dt) : 1;
  setup.frame_dt = settings.fixed_dt;
  setup.substeps = std::max(settings.cloth_substeps, solver_steps);
  if (settings.tier == BulletClothSettings::Tier::realtime) {
    if (settings.realtime_iterations < 1) throw Error("", "bullet.realtime_iterations", "must be >= 1");
    if (!(settings.max_stretch > 0.0)) throw Error("", "bullet.max_stretch", "must be > 0");
    if (!(settings.tether_stretch >= 0.0)) throw Error("", "bullet.tether_stretch", "must be >= 0");
    setup.solver = cloth::SolverSettings{};
    setup.solver.method = settings.realtime_solver;
    if (settings.realtime_substeps < 1) throw Error("", "bullet.realtime_substeps", "must be >= 1");
    if (settings.coupling_iterations < 1) throw Error("", "bullet.coupling_iterations", "must be >= 1");
    setup.solver.params["iterations"] = settings.realtime_iterations;
    setup.strain_limit.reset();  // BodyCoupling limits edges and tethers
    setup.substeps = std::max(setup.substeps, settings.realtime_substeps);
  }
  sim_ = std::make_unique<cloth::Simulation>(std::move(setup));
  auto attach = std::make_unique<AttachStage>(*this);
  AttachStage* attach_ptr = attach.get();
  sim_->add_stage(std::make_unique<PoseStage>(*this), cloth::Simulation::Slot::before_solve);
  sim_->add_stage(std::move(attach), cloth::Simulation::Slot::before_solve);
  if (settings.tier == BulletClothSettings::Tier::realtime) {
    BodyCouplingSettings bs;
    bs.thickness = thickness;
    bs.max_stretch = settings.max_stretch;
    bs.tether_stretch = settings.tether_stretch;
    bs.iterations = settings.coupling_iterations;
    bs.tether_anchors = settings.tether_anchors;
    bs.friction = settings.friction;
    bs.static_friction = std::max(settings.friction, settings.static_friction);
    coupling_ = std::make_unique<BodyCoupling>(colliders_, bs);
    sim_->add_stage(coupling_->make_predict_stage(), cloth::Simulation::Slot::before_solve);
    sim_->add_stage(coupling_->make_solve_stage(), cloth::Simulation::Slot::after_solve);
  } else if (settings.contacts == BulletClothSettings::Contacts::body_collision) {
    // The collision library's stage (CCD, proximity, friction, edges, reaction impulses).
    collision::BodyCollisionSettings bs;
    bs.thickness = thickness;
    bs.friction = settings.friction;
    bs.static_friction = std::max(settings.friction, settings.static_friction);
    bs.contact_normals = sim_->setup().solver.holds_contacts();  // only a solver that reads them
    auto body = std::make_unique<collision::BodyCollisionStage>(colliders_, bs);
    body_ = body.get();
    sim_->add_stage(std::move(body), cloth::Simulation::Slot::after_solve);
  } else {
    // Contacts::features, or Contacts::vertex: the same stage without its face phase.
    collision::FeatureContactSettings fs;
    fs.thickness = thickness;
    fs.friction = settings.friction;
    fs.static_friction = std::max(settings.friction, settings.static_friction);
    fs.faces = settings.contacts != BulletClothSettings::Contacts::vertex;
    auto features = std::make_unique<collision::FeatureContactStage>(colliders_, fs);
    features_ = features.get();
    sim_->add_stage(std::move(features), cloth::Simulation::Slot::after_solve);
  }
  thickness_ = thickness;
  sim_->add_stage(std::make_unique<ReactionStage>(*this, *attach_ptr), cloth::Simulation::Slot::after_solve);

  auto box = std::make_unique<btBoxShape>(btVector3(0.5, 0.5, 0.5));
  box->setMargin(0);
  aabb_shape_ = std::move(box);
  object_ = std::make_unique<ClothObject>(this);
  object_->setCollisionShape(aabb_shape_.get());
  object_->setCollisionFlags(object_->getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
  object_->setActivationState(DISABLE_DEACTIVATION);
  update_aabb();
}

BulletCloth::~BulletCloth() {
  if (world_) remove_from(world_);
}

void BulletCloth::add_to(btDynamicsWorld* world) {
  if (world_) throw Error("", "BulletCloth", "already in a world");
  world_ = world;
  // Group: sensor; mask 0: the object makes no broad-phase pairs, but aabbTest queries see it.
  world->addCollisionObject(object_.get(), btBroadphaseProxy::SensorTrigger, 0);
  world->addAction(this);
  update_aabb();
}

void BulletCloth::remove_from(btDynamicsWorld* world) {
  world->removeAction(this);
  world->removeCollisionObject(object_.get());
  if (world == world_) world_ = nullptr;
}

BulletCloth::BodyTrack& BulletCloth::track(btRigidBody* body) {
  auto it = tracks_.find(body);
  if (it == tracks_.end()) it = tracks_.emplace(body, std::make_unique<BodyTrack>()).first;
  return *it->second;
}

void BulletCloth::attach(int cloth, int vertex, btRigidBody* body) {
  auto& cloths = sim_->cloths();
  if (cloth < 0 || cloth >= static_cast<int>(cloths.size()))
    throw Error("", "attach", "cloth " + std::to_string(cloth) + " out of range");
  cloth::ClothState& s = cloths[cloth]->state();
  if (vertex < 0 || vertex >= s.size())
    throw Error("", "attach", "vertex " + std::to_string(vertex) + " out of range");
  if (!body) throw Error("", "attach", "no body");
  Attachment a;
  a.cloth = cloth;
  a.vertex = vertex;
  a.body = body;
  const Transform pose = to_eigen(body->getWorldTransform());
  a.offset = pose.inverse(Eigen::Isometry) * s.x[vertex];
  s.inv_mass[vertex] = 0.0;
  s.v[vertex] = Vec3::Zero();
  attachments_.push_back(a);
  BodyTrack& tr = track(body);
  if (!tr.initialised) {
    // Known from now on: the next pose Bullet reports is interpolated from this one.
    tr.start = tr.end = tr.from = tr.target = pose;
    tr.initialised = true;
    tr.seen = substeps_ - 1;
  }
}

void BulletCloth::warn(const std::string& shape_name) {
  if (std::find(warnings_.begin(), warnings_.end(), shape_name) != warnings_.end()) return;
  warnings_.push_back(shape_name);
  if (warn_) warn_(shape_name);
}

namespace {

struct Collect final : btBroadphaseAabbCallback {
  std::vector<btCollisionObject*> objects;
  const btCollisionObject* self = nullptr;
  bool process(const btBroadphaseProxy* proxy) override {
    auto* o = static_cast<btCollisionObject*>(proxy->m_clientObject);
    if (o != self) objects.push_back(o);
    return true;
  }
};

}  // namespace

void BulletCloth::updateAction(btCollisionWorld* world, btScalar dt_bt) {
  const double dt = dt_bt;
  if (std::abs(dt - settings_.fixed_dt) > 1e-6 * settings_.fixed_dt)
    throw Error("", "BulletCloth",
                "Bullet substep " + std::to_string(dt) + " s differs from fixed_dt " +
                    std::to_string(settings_.fixed_dt) + " s (use stepSimulation(frame, max, fixed_dt))");
  // A stop request (Simulation::set_stop_flag): no cloth step, no reaction on the bodies, for the rest of
  // the frame (BulletScene::interrupted).
  if (sim_->stop_requested()) return;
  const std::vector<btRigidBody*> bodies = candidate_bodies(world);
  std::vector<btRigidBody*> coupled;  // Tier::realtime: dynamic bodies solved with the cloth
  make_colliders(bodies, dt, coupled);

  // 3. Step the cloth over [t0, t0 + dt], in as many steps as the relative motion needs (settings).
  const int steps = cloth_step_count(bodies, dt);
  if (steps != sim_->setup().substeps) sim_->set_substeps(steps);
  cloth_steps_ += steps;
  substep_t0_ = sim_->time();
  double pen = 0.0;
  last_stats_ = sim_->step_frame();
  if (sim_->interrupted()) return;  // back at this substep's start: no reaction from an abandoned step
  pen = coupling_   ? coupling_->last_penetration()
        : features_ ? features_->last_penetration()
                    : std::max(0.0, body_->max_deficit() - thickness_);
  apply_coupled_solve(coupled);
  last_penetration_ = pen;
  ++substeps_;
  apply_reactions(bodies);
  update_aabb();
}

std::vector<btRigidBody*> BulletCloth::candidate_bodies(btCollisionWorld* world) {
  // 1. Candidates: bodies overlapping the inflated cloth AABB, plus attached bodies; ordered by proxy id.
  Vec3 lo, hi;
  cloth_aabb(lo, hi);
  const double pad = settings_.query_margin + contacts_thickness();
  Collect cb;
  cb.self = object_.get();
  world->getBroadphase()->aabbTest(to_bt(Vec3(lo.array() - pad)), to_bt(Vec3(hi.array() + pad)), cb);
  std::vector<btRigidBody*> bodies;
  for (btCollisionObject* o : cb.objects) {
    btRigidBody* rb = btRigidBody::upcast(o);
    if (!rb) {
      if (o->getInternalType() != btCollisionObject::CO_USER_TYPE)
        warn(std::string("non-rigid collision object (") + o->getCollisionShape()->getName() + ")");
      continue;
    }
    if (rb->getBroadphaseHandle()) bodies.push_back(rb);
  }
  for (const Attachment& a : attachments_) bodies.push_back(a.body);
  std::sort(bodies.begin(), bodies.end(), [](const btRigidBody* a, const btRigidBody* b) {
    const int ia = a->getBroadphaseHandle() ? a->getBroadphaseHandle()->m_uniqueId : -1;
    const int ib = b->getBroadphaseHandle() ? b->getBroadphaseHandle()->m_uniqueId : -1;
    return ia < ib;
  });
  bodies.erase(std::unique(bodies.begin(), bodies.end()), bodies.end());
  return bodies;
}

void BulletCloth::advance_pose(BodyTrack& tr, btRigidBody* rb, double dt) {
  const Transform now = to_eigen(rb->getWorldTransform());
  if (rb->isKinematicObject()) {
    if (!tr.initialised || tr.seen != substeps_ - 1) {
      tr.from = tr.target = now;
      tr.tau = tr.span = 0.0;
    } else if (now.matrix() != tr.target.matrix()) {
      tr.from = tr.target;
      tr.target = now;
      tr.tau = 0.0;
      // Bullet set the velocity to (target - from) / (fixed_dt * n) for the n substeps of this call.
      const double dx = (tr.target.translation() - tr.from.translation()).norm();
      const double da = Eigen::AngleAxisd(tr.target.linear() * tr.from.linear().transpose()).angle();
      const double v = to_eigen(rb->getLinearVelocity()).norm(),
                   w = to_eigen(rb->getAngularVelocity()).norm();
      double span = dt;
      if (v > 1e-12 && dx > 0.0) {
        span = dx / v;
      } else if (w > 1e-12 && da > 0.0) {
        span = da / w;
      }
      span = std::max(1.0, std::round(span / dt)) * dt;
      tr.span = span;
    }
    tr.start = tr.span > 0 ? slerp(tr.from, tr.target, std::min(1.0, tr.tau / tr.span)) : tr.target;
    tr.tau += dt;
    tr.end = tr.span > 0 ? slerp(tr.from, tr.target, std::min(1.0, tr.tau / tr.span)) : tr.target;
  } else if (rb->isStaticObject()) {
    tr.start = tr.end = now;
  } else {
    // Dynamic: integrateTransforms moved it with its current velocities over dt; step back.
    tr.end = now;
    tr.start = now;
    tr.start.translation() -= dt * to_eigen(rb->getLinearVelocity());
    const Vec3 w = to_eigen(rb->getAngularVelocity());
    if (w.norm() > 0)
      tr.start.linear() = Eigen::AngleAxisd(-w.norm() * dt, w.normalized()).toRotationMatrix() * now.linear();
  }
  tr.initialised = true;
  tr.seen = substeps_;
}

void BulletCloth::map_body_shape(BodyTrack& tr, btRigidBody* rb) {
  if (tr.local_of == rb->getCollisionShape()) return;
  tr.local.clear();
  std::vector<std::string> unsupported;
  map_shape(rb->getCollisionShape(), Transform::Identity(),
            "body" + std::to_string(rb->getBroadphaseHandle() ? rb->getBroadphaseHandle()->m_uniqueId : -1),
            tr.local, unsupported);
  for (const std::string& u : unsupported) warn(u);
  for (Collider& c : tr.local) collision::prepare_collider(c);
  tr.local_of = rb->getCollisionShape();
}

int BulletCloth::add_coupled_body(const BodyTrack& tr, btRigidBody* rb, std::vector<btRigidBody*>& coupled) {
  if (!(coupling_ && !rb->isStaticOrKinematicObject() && rb->getInvMass() > 0 &&
        std::none_of(attachments_.begin(), attachments_.end(),
                     [rb](const Attachment& a) { return a.body == rb; })))
    return -1;
  CoupledBody cb;
  cb.inv_mass = rb->getInvMass();
  cb.inv_inertia_local = to_eigen(rb->getInvInertiaDiagLocal());
  cb.pose = cb.pose0 = tr.start;
  cb.v = to_eigen(rb->getLinearVelocity());
  cb.w = to_eigen(rb->getAngularVelocity());
  const Eigen::Matrix3d R = tr.start.linear();
  cb.inv_inertia = R * cb.inv_inertia_local.asDiagonal() * R.transpose();
  const int coupled_index = static_cast<int>(coupling_->bodies.size());
  coupling_->bodies.push_back(cb);
  coupled.push_back(rb);
  return coupled_index;
}

void BulletCloth::make_colliders(const std::vector<btRigidBody*>& bodies, double dt,
                                 std::vector<btRigidBody*>& coupled) {
  // 2. Poses at the substep's start and end; colliders.
  colliders_->clear();
  collider_body_.clear();
  collider_local_.clear();
  if (coupling_) {
    coupling_->bodies.clear();
    coupling_->collider_body.clear();
    coupling_->collider_local.clear();
    coupling_->colliders_changed();
  }
  for (btRigidBody* rb : bodies) {
    BodyTrack& tr = track(rb);
    advance_pose(tr, rb, dt);
    tr.step_impulse.setZero();
    tr.step_moment.setZero();
    map_body_shape(tr, rb);
    const int coupled_index = add_coupled_body(tr, rb, coupled);
    for (const Collider& c : tr.local) {
      if (coupling_) {
        coupling_->collider_body.push_back(coupled_index);
        coupling_->collider_local.push_back(c.curr);
      }
      Collider w = c;
      w.friction = settings_.friction;
      w.static_friction = std::max(w.static_friction, w.friction);
      w.prev = tr.start * c.prev;
      w.curr = tr.start * c.curr;  // PoseStage sets the per-step poses; curr's origin starts the moment sum
      w.reaction_impulse.setZero();
      w.reaction_angular_impulse.setZero();
      colliders_->push_back(std::move(w));
      collider_body_.push_back(rb);
      collider_local_.push_back(c.curr);
    }
  }
}

int BulletCloth::min_cloth_steps() const {
  return coupling_ ? std::max(settings_.cloth_substeps, settings_.realtime_substeps)
                   : settings_.cloth_substeps;
}

int BulletCloth::cloth_step_count(const std::vector<btRigidBody*>& bodies, double dt) const {
  int steps = min_cloth_steps();
  if (settings_.max_cloth_substeps > steps && !colliders_->empty()) {
    double v_cloth = 0.0;  // m/s
    for (const auto& c : sim_->cloths())
      for (const Vec3& v : c->state().v) v_cloth = std::max(v_cloth, v.squaredNorm());
    const double cloth_motion = std::sqrt(v_cloth) * dt;  // m
    Vec3 lo, hi;
    cloth_aabb(lo, hi);
    // Only a body the cloth can reach in this substep needs the finer steps: one whose colliders come
    // within the cloth's and its own motion, the contact thickness and the query margin of the cloth's
    // box (a ground plane far under a hanging cloth is a broad-phase candidate at every substep).
    double motion = 0.0;  // m
    bool near = false;
    for (btRigidBody* rb : bodies) {
      const BodyTrack& tr = *tracks_.at(rb);
      double reach = 0.0;
      for (const Collider& c : tr.local) reach = std::max(reach, reach_from_origin(c));
      const double angle = Eigen::AngleAxisd(tr.end.linear() * tr.start.linear().transpose()).angle();
      const double body_motion = (tr.end.translation() - tr.start.translation()).norm() + angle * reach;
      const double gap = body_motion + cloth_motion + contacts_thickness() + settings_.query_margin;
      bool body_near = false;
      for (const Collider& c : tr.local)
        body_near |= std::min(distance_bound(c, tr.start, lo, hi), distance_bound(c, tr.end, lo, hi)) < gap;
      if (!body_near) continue;
      near = true;
      motion = std::max(motion, body_motion);
    }
    if (!near) return steps;
    motion += cloth_motion;
    const double need = std::ceil(motion / (settings_.step_motion * contacts_thickness()));
    if (need > steps) steps = static_cast<int>(std::min<double>(need, settings_.max_cloth_substeps));
  }
  return steps;
}

void BulletCloth::apply_coupled_solve(const std::vector<btRigidBody*>& coupled) {
  // Tier::realtime: the bodies the cloth moved take their pose and velocity from the coupled solve.
  for (size_t b = 0; b < coupled.size(); ++b) {
    const CoupledBody& cb = coupling_->bodies[b];
    if (!cb.touched) continue;
    btRigidBody* rb = coupled[b];
    BodyTrack& tr = *tracks_.at(rb);
    const Vec3 dp = (cb.v - to_eigen(rb->getLinearVelocity())) / rb->getInvMass();
    tr.applied += dp;
    tr.end = cb.pose;
    rb->activate();
    rb->setCenterOfMassTransform(to_bt(cb.pose));
    rb->setLinearVelocity(to_bt(cb.v));
    rb->setAngularVelocity(to_bt(cb.w));
  }
}

void BulletCloth::apply_reactions(const std::vector<btRigidBody*>& bodies) {
  // 4. Reactions to dynamic bodies: linear impulse and the moment about the centre of mass.
  for (size_t k = 0; k < colliders_->size(); ++k) {
    const Collider& c = (*colliders_)[k];
    BodyTrack& tr = *tracks_.at(collider_body_[k]);
    tr.step_impulse += c.reaction_impulse;
    tr.step_moment +=
        c.reaction_angular_impulse + (c.curr.translation() - tr.end.translation()).cross(c.reaction_impulse);
  }
  for (btRigidBody* rb : bodies) {
    BodyTrack& tr = *tracks_.at(rb);
    if (rb->isStaticOrKinematicObject() || rb->getInvMass() == 0) continue;
    if (tr.step_impulse.squaredNorm() == 0.0 && tr.step_moment.squaredNorm() == 0.0) continue;
    rb->activate();
    rb->applyCentralImpulse(to_bt(tr.step_impulse));
    rb->applyTorqueImpulse(to_bt(tr.step_moment));
    tr.applied += tr.step_impulse;
  }
}

double BulletCloth::contacts_thickness() const { return thickness_ > 0.0 ? thickness_ : settings_.thickness; }

void BulletCloth::cloth_aabb(Vec3& lo, Vec3& hi) const {
  lo = Vec3::Constant(HUGE_VAL);
  hi = Vec3::Constant(-HUGE_VAL);
  for (const auto& c : sim_->cloths())
    for (const Vec3& x : c->state().x) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
  if (!(lo.array() <= hi.array()).all()) lo = hi = Vec3::Zero();
}

void BulletCloth::update_aabb() {
  Vec3 lo, hi;
  cloth_aabb(lo, hi);
  const double t = contacts_thickness();
  const Vec3 size = (hi - lo).array() + 2.0 * t + 1e-6;
  aabb_shape_->setLocalScaling(to_bt(size));
  btTransform tf;
  tf.setIdentity();
  tf.setOrigin(to_bt(Vec3(0.5 * (lo + hi))));
  object_->setWorldTransform(tf);
  if (world_ && object_->getBroadphaseHandle()) world_->updateSingleAabb(object_.get());
}

void BulletCloth::debugDraw(btIDebugDraw* drawer) {
  if (!drawer) return;
  for (const auto& c : sim_->cloths()) {
    const cloth::ClothState& s = c->state();
    for (const cloth::Tri& t : c->mesh().triangles())
      for (int e = 0; e < 3; ++e)
        drawer->drawLine(to_bt(s.x[t[e]]), to_bt(s.x[t[(e + 1) % 3]]), btVector3(0.8, 0.8, 0.8));
  }
}

RayHit BulletCloth::ray_test(const Vec3& from, const Vec3& to) const {
  RayHit best;
  const auto& cloths = sim_->cloths();
  if (casters_.size() != cloths.size()) {
    casters_.clear();
    for (const auto& c : cloths) casters_.push_back(std::make_unique<ClothRayCaster>(c->mesh_ptr()));
  }
  for (size_t k = 0; k < cloths.size(); ++k) {
    RayHit h = casters_[k]->cast(cloths[k]->state().x, from, to);
    if (h.hit && (!best.hit || h.distance < best.distance)) {
      best = h;
      best.cloth = static_cast<int>(k);
    }
  }
  return best;
}

Vec3 BulletCloth::applied_impulse(const btRigidBody* body) const {
  auto it = tracks_.find(body);
  return it == tracks_.end() ? Vec3::Zero() : it->second->applied;
}

Transform BulletCloth::body_pose(const btRigidBody* body) const {
  auto it = tracks_.find(body);
  return it == tracks_.end() ? Transform::Identity() : it->second->end;
}

}  // namespace loom::bullet
