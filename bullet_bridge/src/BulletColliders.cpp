#include "loom/bullet/BulletColliders.h"

#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <cmath>
#include <iterator>

#include "BulletConvert.h"
#include "loom/bullet/BulletCloth.h"
#include "loom/cloth/Error.h"
#include "loom/collision/ColliderGeometry.h"

namespace loom::bullet {

using collision::Collider;
using collision::Transform;

namespace {

Transform pose_slerp(const Transform& a, const Transform& b, double f) {
  Transform out = Transform::Identity();
  const Eigen::Quaterniond qa(a.linear()), qb(b.linear());
  out.linear() = qa.slerp(f, qb).toRotationMatrix();
  out.translation() = (1.0 - f) * a.translation() + f * b.translation();
  return out;
}

struct CollectBodies final : btBroadphaseAabbCallback {
  std::vector<btRigidBody*> bodies;
  bool process(const btBroadphaseProxy* proxy) override {
    auto* o = static_cast<btCollisionObject*>(proxy->m_clientObject);
    if (btRigidBody* rb = btRigidBody::upcast(o)) bodies.push_back(rb);
    return true;
  }
};

void check_setting(double value, double lo, const std::string& source, const char* field) {
  if (!(value >= lo) || !std::isfinite(value))
    throw Error(source, field, std::to_string(value) + " must be finite and >= " + std::to_string(lo));
}

}  // namespace

// A body's poses over the current frame: `start` at t0, `end` at t1 (centre-of-mass frames).
struct BulletColliders::Track {
  Transform start = Transform::Identity(), end = Transform::Identity();
  long seen = -2;                               // the update it was last listed in
  Transform reference = Transform::Identity();  // the wake-up reference pose
  long reference_epoch = -1;                    // the reset_references epoch it was taken in
  Vec3 applied = Vec3::Zero();                  // N s, summed impulse given to the body
  std::vector<Collider> local;                  // the shape's colliders in the body frame
  const btCollisionShape* local_of = nullptr;
};

BulletColliders::BulletColliders(btCollisionWorld* world, const BulletCollidersSettings& settings,
                                 const std::string& source)
    : world_(world),
      settings_(settings),
      source_(source),
      colliders_(std::make_shared<collision::ColliderSet>()) {
  if (!world_) throw Error(source_, "world", "is null");
  check_setting(settings_.query_margin, 0.0, source_, "query_margin");
  check_setting(settings_.thickness, 0.0, source_, "thickness");
  check_setting(settings_.friction, 0.0, source_, "friction");
  check_setting(settings_.static_friction, settings_.friction, source_, "static_friction");
}

BulletColliders::~BulletColliders() = default;

BulletColliders::Track& BulletColliders::track(btRigidBody* body) {
  auto it = tracks_.find(body);
  if (it == tracks_.end()) it = tracks_.emplace(body, std::make_unique<Track>()).first;
  return *it->second;
}

void BulletColliders::update(const Vec3& lo, const Vec3& hi, double t0, double t1) {
  if (!lo.allFinite() || !hi.allFinite() || (lo.array() > hi.array()).any())
    throw Error(source_, "box", "must be finite with lo <= hi");
  if (!std::isfinite(t0) || !std::isfinite(t1) || t1 < t0)
    throw Error(source_, "time", "must be finite with t0 <= t1");
  ++updates_;
  const double pad = settings_.query_margin;
  CollectBodies cb;
  world_->getBroadphase()->aabbTest(to_bt(Vec3(lo.array() - pad)), to_bt(Vec3(hi.array() + pad)), cb);
  bodies_.clear();
  for (btRigidBody* rb : cb.bodies)
    if (rb->getBroadphaseHandle()) bodies_.push_back(rb);
  std::sort(bodies_.begin(), bodies_.end(), [](const btRigidBody* a, const btRigidBody* b) {
    return a->getBroadphaseHandle()->m_uniqueId < b->getBroadphaseHandle()->m_uniqueId;
  });
  bodies_.erase(std::unique(bodies_.begin(), bodies_.end()), bodies_.end());

  colliders_->clear();
  collider_body_.clear();
  const double dt = t1 - t0;
  for (size_t b = 0; b < bodies_.size(); ++b) {
    btRigidBody* rb = bodies_[b];
    Track& tr = track(rb);
    const Transform now = to_eigen(rb->getWorldTransform());
    if (tr.seen == updates_ - 1) {
      tr.start = tr.end;
    } else {  // not seen last frame: step back along its velocities (static bodies have none)
      tr.start = now;
      tr.start.translation() -= dt * to_eigen(rb->getLinearVelocity());
      const Vec3 w = to_eigen(rb->getAngularVelocity());
      if (w.norm() > 0.0)
        tr.start.linear() =
            Eigen::AngleAxisd(-w.norm() * dt, w.normalized()).toRotationMatrix() * now.linear();
    }
    tr.end = now;
    tr.seen = updates_;
    if (tr.reference_epoch != epoch_) tr.reference = now, tr.reference_epoch = epoch_;
    if (tr.local_of != rb->getCollisionShape()) {
      tr.local.clear();
      std::vector<std::string> unsupported;
      map_shape(rb->getCollisionShape(), Transform::Identity(),
                "body" + std::to_string(rb->getBroadphaseHandle()->m_uniqueId), tr.local, unsupported);
      for (const std::string& u : unsupported)
        if (std::find(warnings_.begin(), warnings_.end(), u) == warnings_.end()) warnings_.push_back(u);
      for (Collider& c : tr.local) collision::prepare_collider(c);
      tr.local_of = rb->getCollisionShape();
    }
    const bool moving = tr.start.matrix() != tr.end.matrix();
    for (const Collider& c : tr.local) {
      Collider w = c;
      w.friction = settings_.friction;
      w.static_friction = settings_.static_friction;
      w.thickness = settings_.thickness;
      w.prev = tr.start * c.curr;
      w.curr = tr.end * c.curr;
      if (moving) {
        const Transform a = tr.start, e = tr.end, local = c.curr;
        w.motion = [a, e, local, t0, dt](double t) {
          const double f = dt > 0.0 ? std::clamp((t - t0) / dt, 0.0, 1.0) : 1.0;
          return Transform(pose_slerp(a, e, f) * local);
        };
      }
      colliders_->push_back(std::move(w));
      collider_body_.push_back(static_cast<int>(b));
    }
  }
  // Bodies out of reach (or removed from the world) are forgotten: one seen again starts a new track.
  for (auto it = tracks_.begin(); it != tracks_.end();)
    it = it->second->seen == updates_ ? std::next(it) : tracks_.erase(it);
}

void BulletColliders::apply_reactions() {
  std::vector<Vec3> impulse(bodies_.size(), Vec3::Zero()), moment(bodies_.size(), Vec3::Zero());
  for (size_t k = 0; k < colliders_->size(); ++k) {
    Collider& c = (*colliders_)[k];
    const int b = collider_body_[k];
    const Vec3 com = tracks_.at(bodies_[b])->end.translation();
    impulse[b] += c.reaction_impulse;
    // L_com = L_origin + (origin - com) x J.
    moment[b] += c.reaction_angular_impulse + (c.curr.translation() - com).cross(c.reaction_impulse);
    c.reaction_impulse.setZero();
    c.reaction_angular_impulse.setZero();
  }
  if (!settings_.reactions) return;
  for (size_t b = 0; b < bodies_.size(); ++b) {
    btRigidBody* rb = bodies_[b];
    if (rb->isStaticOrKinematicObject() || !(rb->getInvMass() > 0)) continue;
    if (impulse[b].squaredNorm() == 0.0 && moment[b].squaredNorm() == 0.0) continue;
    rb->activate();
    rb->applyCentralImpulse(to_bt(impulse[b]));
    rb->applyTorqueImpulse(to_bt(moment[b]));
    // try_emplace with an explicit zero: map::operator[] would value-initialise the Eigen vector, which
    // leaves its coefficients uninitialised.
    applied_.try_emplace(rb, Vec3::Zero()).first->second += impulse[b];
  }
}

std::vector<std::pair<Vec3, Vec3>> BulletColliders::moved_boxes(double distance, double angle) const {
  std::vector<std::pair<Vec3, Vec3>> out;
  for (btRigidBody* rb : bodies_) {
    if (rb->isStaticObject() && !rb->isKinematicObject()) continue;  // mass 0 flags kinematic ones static too
    const Track& tr = *tracks_.at(rb);
    const double moved = (tr.end.translation() - tr.reference.translation()).norm();
    const double turned = Eigen::AngleAxisd(tr.end.linear() * tr.reference.linear().transpose()).angle();
    if (!(moved > distance || turned > angle)) continue;
    btVector3 a, b;
    rb->getAabb(a, b);
    out.emplace_back(to_eigen(a), to_eigen(b));
  }
  return out;
}

Vec3 BulletColliders::applied_impulse(const btRigidBody* body) const {
  auto it = applied_.find(body);
  return it == applied_.end() ? Vec3::Zero() : it->second;
}

}  // namespace loom::bullet
