#pragma once
// Colliders as drawn, shared by the offscreen Renderer and the viewer (GL-free): each collider's shape is
// tessellated once (ColliderMesh.h) and posed at its current pose `curr` every frame. A horizontal plane
// collider (normal +y) is the ground itself: it is not drawn, the ground is put at its height instead.
#include <optional>
#include <vector>

#include "loom/collision/ColliderMesh.h"
#include "loom/render/Renderer.h"

namespace loom::render::gl {

class ColliderShapes {
 public:
  // Re-tessellates when the set's size or shape types changed; `plane_half_size` (m): tilted planes' squares.
  void update(const collision::ColliderSet& set, double plane_half_size);
  // The colliders at their `curr` poses (world, m), ground planes left out.
  std::vector<collision::ColliderMesh> posed(const collision::ColliderSet& set) const;

 private:
  std::vector<collision::ShapeType> types_;
  std::vector<collision::ColliderMesh> local_;  // empty mesh for ground planes
};

// Height (m) of the highest plane collider facing +y, if any (the ground drawn there).
std::optional<double> ground_plane(const collision::ColliderSet& set);
// Adds every collider except planes, at its `curr` pose, to `b` (its local box's corners).
void add_collider_bounds(Bounds& b, const collision::ColliderSet& set);

}  // namespace loom::render::gl
