#pragma once
// ColliderBroadPhase: which colliders can touch a region this step (docs/collision.md). FCL's dynamic AABB
// tree (fcl::DynamicAABBTreeCollisionManager) over each collider's swept box: the world boxes at prev and
// curr (plus, for a rotating collider, the ball its local box sweeps about the moving origin), inflated by a
// margin; recomputed from the poses at every update (the manager is refitted with update(), never left with
// stale boxes: FCL's manager misses moved objects whose box was not recomputed). Planes are unbounded and
// always returned.
#include <memory>
#include <vector>

#include "loom/collision/ClothBvh.h"
#include "loom/collision/Collider.h"

namespace loom::collision {

// World box of collider c over its step prev -> curr, inflated by margin (m); planes: infinite.
Aabb swept_collider_box(const Collider& c, double margin);

class ColliderBroadPhase {
 public:
  ColliderBroadPhase();
  ~ColliderBroadPhase();
  ColliderBroadPhase(const ColliderBroadPhase&) = delete;
  ColliderBroadPhase& operator=(const ColliderBroadPhase&) = delete;

  // Recomputes every collider's swept box (margin per collider, m); re-registers when the count changed.
  void update(const ColliderSet& colliders, const std::vector<double>& margins);
  // Indices of the colliders whose swept box overlaps `box`, ascending (planes included).
  std::vector<int> query(const Aabb& box) const;
  const Aabb& box(int k) const { return boxes_[k]; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<Aabb> boxes_;
  std::vector<int> planes_;
};

}  // namespace loom::collision
