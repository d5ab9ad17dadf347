#include "gl/ColliderShapes.h"

#include <cmath>

#include "loom/collision/ColliderGeometry.h"

namespace loom::render::gl {

namespace {

bool is_ground(const collision::Collider& c) {
  return c.shape.type == collision::ShapeType::plane &&
         (c.curr.linear() * cloth::Vec3::UnitY()).y() > 1.0 - 1e-9;
}

}  // namespace

void ColliderShapes::update(const collision::ColliderSet& set, double plane_half_size) {
  bool same = types_.size() == set.size();
  for (size_t k = 0; same && k < set.size(); ++k) same = types_[k] == set[k].shape.type;
  if (same) return;
  types_.clear();
  local_.clear();
  for (const collision::Collider& c : set) {
    types_.push_back(c.shape.type);
    collision::TessellationSettings ts;
    ts.plane_half_size = plane_half_size;
    local_.push_back(is_ground(c) ? collision::ColliderMesh{}
                                  : collision::tessellate(c.shape, c.geometry.get(), ts));
  }
}

std::vector<collision::ColliderMesh> ColliderShapes::posed(const collision::ColliderSet& set) const {
  std::vector<collision::ColliderMesh> out;
  for (size_t k = 0; k < set.size() && k < local_.size(); ++k)
    if (!local_[k].triangles.empty() && !is_ground(set[k]))
      out.push_back(collision::transformed(local_[k], set[k].curr));
  return out;
}

std::optional<double> ground_plane(const collision::ColliderSet& set) {
  std::optional<double> g;
  for (const collision::Collider& c : set)
    if (is_ground(c) && (!g || c.curr.translation().y() > *g)) g = c.curr.translation().y();
  return g;
}

void add_collider_bounds(Bounds& b, const collision::ColliderSet& set) {
  for (const collision::Collider& c : set) {
    if (c.shape.type == collision::ShapeType::plane) continue;
    cloth::Vec3 lo, hi;
    std::shared_ptr<const collision::ColliderGeometry> g = c.geometry;
    if (!g && (c.shape.type == collision::ShapeType::convex || c.shape.type == collision::ShapeType::mesh))
      g = collision::build_collider_geometry(c.shape, c.name);
    collision::local_bounds(c.shape, g.get(), lo, hi);
    for (int i = 0; i < 8; ++i)
      b.add(c.curr * cloth::Vec3(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z()));
  }
}

}  // namespace loom::render::gl
