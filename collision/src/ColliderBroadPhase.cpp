#include "loom/collision/ColliderBroadPhase.h"

#include <algorithm>
#include <cmath>

#include "FclShape.h"
#include "loom/collision/ColliderGeometry.h"
#include "loom/collision/SweptCollider.h"

namespace loom::collision {

namespace {

Aabb world_box(const Vec3& lo, const Vec3& hi, const Transform& pose) {
  Aabb b;
  for (int k = 0; k < 8; ++k)
    b.grow(pose * Vec3((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), (k & 4) ? hi.z() : lo.z()));
  return b;
}

}  // namespace

Aabb swept_collider_box(const Collider& c, double margin) {
  Aabb b;
  if (c.shape.type == ShapeType::plane) {
    b.lo = Vec3::Constant(-HUGE_VAL), b.hi = Vec3::Constant(HUGE_VAL);
    return b;
  }
  Vec3 lo, hi;
  local_bounds(c.shape, c.geometry.get(), lo, hi);
  b.grow(world_box(lo, hi, c.prev));
  b.grow(world_box(lo, hi, c.curr));
  if (rotation_angle(c.prev, c.curr) > 0.0) {
    // In between, the local box stays within a ball of radius |centre| + half diagonal about the origin,
    // which moves on the segment c0 -> c1.
    const double r = (0.5 * (lo + hi)).norm() + 0.5 * (hi - lo).norm();
    for (const Transform* t : {&c.prev, &c.curr}) {
      b.grow(Vec3(t->translation() - Vec3::Constant(r)));
      b.grow(Vec3(t->translation() + Vec3::Constant(r)));
    }
  }
  b.lo -= Vec3::Constant(margin);
  b.hi += Vec3::Constant(margin);
  return b;
}

struct ColliderBroadPhase::Impl {
  fcl::DynamicAABBTreeCollisionManagerd manager;
  std::vector<std::shared_ptr<fcl::Boxd>> shapes;
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects;
  std::vector<int> ids;  // user data: the collider index of each object
};

ColliderBroadPhase::ColliderBroadPhase() : impl_(std::make_unique<Impl>()) {}
ColliderBroadPhase::~ColliderBroadPhase() = default;

namespace {

// An axis-aligned fcl::Box translated to the box's centre has exactly that world AABB.
void place(fcl::Boxd& shape, fcl::CollisionObjectd& obj, const Aabb& b) {
  shape.side = (b.hi - b.lo).cwiseMax(0.0);
  shape.computeLocalAABB();
  obj.setTransform(fcl::Transform3d(Eigen::Translation3d(0.5 * (b.lo + b.hi))));
  obj.computeAABB();
}

}  // namespace

void ColliderBroadPhase::update(const ColliderSet& colliders, const std::vector<double>& margins) {
  const int n = static_cast<int>(colliders.size());
  boxes_.resize(n);
  planes_.clear();
  for (int k = 0; k < n; ++k) {
    boxes_[k] = swept_collider_box(colliders[k], margins[k]);
    if (colliders[k].shape.type == ShapeType::plane) planes_.push_back(k);
  }
  Impl& m = *impl_;
  const bool rebuild = static_cast<int>(m.ids.size()) != n;
  if (rebuild) {
    m.manager.clear();
    m.shapes.clear(), m.objects.clear(), m.ids.assign(n, 0);
    std::vector<fcl::CollisionObjectd*> registered;
    for (int k = 0; k < n; ++k) {
      m.ids[k] = k;
      m.shapes.push_back(std::make_shared<fcl::Boxd>(1.0, 1.0, 1.0));
      m.objects.push_back(std::make_unique<fcl::CollisionObjectd>(m.shapes.back()));
      m.objects.back()->setUserData(&m.ids[k]);
    }
    for (int k = 0; k < n; ++k) {
      if (colliders[k].shape.type == ShapeType::plane) continue;
      place(*m.shapes[k], *m.objects[k], boxes_[k]);
      registered.push_back(m.objects[k].get());
    }
    m.manager.registerObjects(registered);
    m.manager.setup();
    return;
  }
  for (int k = 0; k < n; ++k) {
    if (colliders[k].shape.type == ShapeType::plane) continue;
    place(*m.shapes[k], *m.objects[k], boxes_[k]);
  }
  m.manager.update();
}

std::vector<int> ColliderBroadPhase::query(const Aabb& box) const {
  std::vector<int> out = planes_;
  if (!impl_->objects.empty()) {
    auto shape = std::make_shared<fcl::Boxd>(1.0, 1.0, 1.0);
    fcl::CollisionObjectd probe(shape);
    place(*shape, probe, box);
    struct Data {
      std::vector<int>* out;
      const fcl::CollisionObjectd* probe;
    } data{&out, &probe};
    impl_->manager.collide(&probe, &data,
                           [](fcl::CollisionObjectd* a, fcl::CollisionObjectd* b, void* cdata) {
                             auto* d = static_cast<Data*>(cdata);
                             const fcl::CollisionObjectd* other = a == d->probe ? b : a;
                             d->out->push_back(*static_cast<const int*>(other->getUserData()));
                             return false;  // keep going
                           });
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace loom::collision
