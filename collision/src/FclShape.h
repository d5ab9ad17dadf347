#pragma once
// The FCL side of a ColliderGeometry (private to loom::collision: only .cpp files include FCL).
#include <fcl/fcl.h>

#include <memory>

namespace loom::collision {

struct FclShape {
  std::shared_ptr<fcl::CollisionGeometry<double>>
      geometry;  // fcl::Convex<double> or BVHModel<OBBRSS<double>>
  bool is_mesh = false;
};

}  // namespace loom::collision
