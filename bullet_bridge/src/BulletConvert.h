#pragma once
// Bullet <-> Eigen conversions (private to the bridge; works for float and double btScalar).
#include <LinearMath/btTransform.h>

#include "loom/collision/Collider.h"

namespace loom::bullet {

inline collision::Vec3 to_eigen(const btVector3& v) { return collision::Vec3(v.x(), v.y(), v.z()); }
inline btVector3 to_bt(const collision::Vec3& v) {
  return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z()));
}

inline collision::Transform to_eigen(const btTransform& t) {
  collision::Transform out = collision::Transform::Identity();
  const btMatrix3x3& b = t.getBasis();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.linear()(r, c) = b[r][c];
  out.translation() = to_eigen(t.getOrigin());
  return out;
}

inline btTransform to_bt(const collision::Transform& t) {
  btMatrix3x3 b;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) b[r][c] = btScalar(t.linear()(r, c));
  return btTransform(b, to_bt(collision::Vec3(t.translation())));
}

}  // namespace loom::bullet
