#pragma once
// RigidBodies: Bullet rigid bodies in one dynamics world, owned with their shapes and motion states, in the
// order added, and removed from the world on destruction (so declare it after the world it lives in, and
// remove any BulletCloth attached to its bodies first). Used by `loom run` (BulletScene), `loom compare`
// (Compare), the bridge tests and the bridge bench. Like BulletCloth.h, it names Bullet types: include it
// only from code linking loom::bullet (or loom::bullet_double).
#include <memory>
#include <vector>

#include "loom/collision/RigidBodySpec.h"

class btCollisionShape;
class btDefaultMotionState;
class btDynamicsWorld;
class btRigidBody;
class btTransform;

namespace loom::bullet {

struct RigidBodies {
  btDynamicsWorld* world = nullptr;
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btDefaultMotionState>> states;
  std::vector<std::unique_ptr<btRigidBody>> bodies;

  explicit RigidBodies(btDynamicsWorld& w);
  RigidBodies(const RigidBodies&) = delete;
  RigidBodies& operator=(const RigidBodies&) = delete;
  ~RigidBodies();

  // A body of `shape` at `pose`, added to the world. mass (kg) 0: static; kinematic: mass 0 and
  // CF_KINEMATIC_OBJECT, never deactivated (move it through its motion state). A dynamic body gets the
  // shape's inertia for `mass`. Friction and restitution are Bullet's defaults (0.5, 0) unless set after.
  btRigidBody* add(std::unique_ptr<btCollisionShape> shape, double mass, const btTransform& pose,
                   bool kinematic = false);

  // Spec `b` (bodies[index] of a scene): a kinematic body (with `motion`) starts at motion(0); a dynamic one
  // gets its mass, inertia, friction, restitution and start velocities. Throws loom::Error naming
  // bodies[index].shape for a shape rigid bodies cannot have.
  btRigidBody* add(const collision::RigidBodySpec& b, size_t index);
};

}  // namespace loom::bullet
