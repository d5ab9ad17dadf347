#include "loom/collision/ContactGuardStage.h"

#include <cmath>
#include <cstdio>

#include "loom/collision/ColliderDistance.h"

namespace loom::collision {

ContactGuardStage::ContactGuardStage(ColliderSetPtr colliders, double max_depth)
    : colliders_(std::move(colliders)), max_depth_(max_depth) {}

void ContactGuardStage::run(cloth::StageContext& ctx) {
  const ColliderSet& cs = *colliders_;
  // Work of the colliders' push over this step (ContactGuardStage.h). The first step starts from the
  // reactions as they are (an owner may have cleared or kept them).
  if (last_impulse_.size() != cs.size()) {
    last_impulse_.assign(cs.size(), Vec3::Zero());
    last_moment_.assign(cs.size(), Vec3::Zero());
  }
  for (size_t k = 0; k < cs.size(); ++k) {
    const Collider& c = cs[k];
    const Vec3 v = (c.curr.translation() - c.prev.translation()) / ctx.h;
    const Eigen::AngleAxisd turn(c.curr.linear() * c.prev.linear().transpose());
    const Vec3 w = turn.axis() * (turn.angle() / ctx.h);
    work_ += std::abs((c.reaction_impulse - last_impulse_[k]).dot(v)) +
             std::abs((c.reaction_angular_impulse - last_moment_[k]).dot(w));
    last_impulse_[k] = c.reaction_impulse;
    last_moment_[k] = c.reaction_angular_impulse;
  }
  // The deepest free vertex inside a collider at the step's end.
  double deepest = 0.0;
  int at_cloth = -1, at_vertex = -1, at_collider = -1;
  for (size_t ci = 0; ci < ctx.cloths.size(); ++ci) {
    const cloth::ClothState& st = ctx.cloths[ci]->state();
    for (int i = 0; i < st.size(); ++i) {
      if (st.inv_mass[i] == 0.0) continue;  // kinematic vertices are placed by their owner
      for (size_t k = 0; k < cs.size(); ++k) {
        const double depth = -signed_distance(cs[k], cs[k].curr, st.x[i], nullptr);
        if (depth > deepest)
          deepest = depth, at_cloth = static_cast<int>(ci), at_vertex = i, at_collider = static_cast<int>(k);
      }
    }
  }
  deepest_ = std::max(deepest_, deepest);
  ++steps_;
  violation_.clear();
  if (max_depth_ > 0.0 && deepest > max_depth_) {
    char buf[32], limit[32];
    std::snprintf(buf, sizeof buf, "%.3g mm", deepest * 1e3);
    std::snprintf(limit, sizeof limit, "%.3g mm", max_depth_ * 1e3);
    violation_ = "could not resolve contacts: vertex " + std::to_string(at_vertex) + " of cloth '" +
                 ctx.cloths[at_cloth]->name() + "' is " + buf + " inside collider '" + cs[at_collider].name +
                 "' (limit " + limit + ")";
  }
}

std::vector<std::pair<std::string, double>> ContactGuardStage::counters() const {
  return {{"deepest_mm", deepest_ * 1e3}, {"steps", static_cast<double>(steps_)}};
}

void ContactGuardStage::save_state(cloth::StateWriter& out) const {
  out.tag("contact_guard");
  out.f64(work_);
  out.vec3s(last_impulse_);
  out.vec3s(last_moment_);
}

void ContactGuardStage::load_state(cloth::StateReader& in) {
  in.tag("contact_guard");
  work_ = in.f64();
  last_impulse_ = in.vec3s();
  last_moment_ = in.vec3s();
  violation_.clear();
}

}  // namespace loom::collision
