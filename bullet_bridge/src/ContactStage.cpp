#include "ContactStage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace loom::bullet {

namespace {

// Radius (m) of a ball around the local origin that holds the shape; infinity for planes.
double bounding_radius(const collision::Shape& s) {
  using collision::ShapeType;
  switch (s.type) {
    case ShapeType::plane: return HUGE_VAL;
    case ShapeType::sphere: return s.radius;
    case ShapeType::capsule: return s.radius + s.half_height;
    case ShapeType::box: return s.half_extents.norm();
    case ShapeType::cylinder: return std::hypot(s.radius, s.half_height);
    case ShapeType::convex:
    case ShapeType::mesh: {
      double r = 0.0;
      for (const Vec3& v : s.vertices) r = std::max(r, v.norm());
      return r;
    }
  }
  return HUGE_VAL;
}

}  // namespace

const HullPlanes* ContactStage::hull_for(const collision::Collider& c) {
  if (c.shape.type != collision::ShapeType::convex) return nullptr;
  const std::string key = c.name + "#" + std::to_string(c.shape.vertices.size());
  auto it = hulls_.find(key);
  if (it == hulls_.end()) it = hulls_.emplace(key, hull_planes(c.shape.vertices)).first;
  return &it->second;
}

void ContactStage::run(cloth::StageContext& ctx) {
  last_penetration_ = 0.0;
  if (!colliders_) return;
  for (collision::Collider& col : *colliders_) {
    const HullPlanes* hull = hull_for(col);
    const double reach = bounding_radius(col.shape) + thickness_;
    const Vec3 centre = col.curr.translation();
    // Maps a point at curr to where the same body point was at prev: its velocity is the difference / h.
    const Transform back = col.prev * col.curr.inverse(Eigen::Isometry);
    const double mu = col.friction;
    for (auto& cl : ctx.cloths) {
      cloth::ClothState& s = cl->state();
      for (int i = 0; i < s.size(); ++i) {
        if (s.inv_mass[i] == 0.0) continue;  // pinned / attached: prescribed
        Vec3& x = s.x[i];
        if ((x - centre).squaredNorm() > reach * reach) continue;
        Vec3 n;
        const double phi = shape_signed_distance(col.shape, hull, col.curr, x, &n);
        if (!(phi < thickness_)) continue;
        ++contacts_;
        last_penetration_ = std::max(last_penetration_, -phi);
        x += (thickness_ - phi) * n;
        const Vec3 vb = (x - back * x) / ctx.h;  // m/s, the body point's velocity
        Vec3& v = s.v[i];
        const Vec3 rel = v - vb;
        const double vn = rel.dot(n);
        if (vn >= 0.0) continue;  // separating: position fix only
        const Vec3 vt = rel - vn * n;
        const double vt_norm = vt.norm();
        // Coulomb: the tangential speed drops by at most mu |vn| (kinetic friction impulse <= mu normal).
        const double keep = vt_norm > 0.0 ? std::max(0.0, 1.0 - mu * (-vn) / vt_norm) : 0.0;
        const Vec3 v_new = vb + keep * vt;
        const Vec3 impulse = s.mass[i] * (v_new - v);  // N s given to the cloth
        v = v_new;
        col.reaction_impulse -= impulse;
        col.reaction_angular_impulse -= (x - centre).cross(impulse);
      }
    }
  }
}

}  // namespace loom::bullet
