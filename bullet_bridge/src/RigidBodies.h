#pragma once
// The Bullet rigid bodies of a scene's `bodies` (collision::RigidBodySpec) in one dynamics world, in `bodies`
// order, owned with their shapes and motion states; removed from the world on destruction (so declare it
// after the world it lives in). Used by `loom run` (BulletScene) and `loom compare` (Compare).
#include <btBulletDynamicsCommon.h>

#include <memory>
#include <string>
#include <vector>

#include "BulletConvert.h"
#include "loom/cloth/Error.h"
#include "loom/collision/RigidBodySpec.h"

namespace loom::bullet {

struct RigidBodies {
  btDynamicsWorld* world = nullptr;
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btDefaultMotionState>> states;
  std::vector<std::unique_ptr<btRigidBody>> bodies;

  explicit RigidBodies(btDynamicsWorld& w) : world(&w) {}
  RigidBodies(const RigidBodies&) = delete;
  RigidBodies& operator=(const RigidBodies&) = delete;
  ~RigidBodies() {
    for (auto& b : bodies) world->removeRigidBody(b.get());
  }

  // Adds spec `b` (bodies[index] of the scene): a kinematic body (with `motion`) starts at motion(0) and is
  // never deactivated; a dynamic one gets its mass, inertia and start velocities.
  void add(const collision::RigidBodySpec& b, size_t index) {
    using collision::ShapeType;
    std::unique_ptr<btCollisionShape> shape;
    switch (b.shape.type) {
      case ShapeType::plane: shape = std::make_unique<btStaticPlaneShape>(btVector3(0, 1, 0), 0); break;
      case ShapeType::sphere: shape = std::make_unique<btSphereShape>(btScalar(b.shape.radius)); break;
      case ShapeType::capsule:
        shape = std::make_unique<btCapsuleShape>(btScalar(b.shape.radius), btScalar(2 * b.shape.half_height));
        break;
      case ShapeType::box: shape = std::make_unique<btBoxShape>(to_bt(b.shape.half_extents)); break;
      case ShapeType::cylinder:
        shape = std::make_unique<btCylinderShape>(
            btVector3(btScalar(b.shape.radius), btScalar(b.shape.half_height), btScalar(b.shape.radius)));
        break;
      default:
        throw Error("", "bodies[" + std::to_string(index) + "].shape",
                    std::string(collision::shape_type_name(b.shape.type)) + " is not supported for rigid bodies");
    }
    const bool kinematic = static_cast<bool>(b.motion);
    states.push_back(std::make_unique<btDefaultMotionState>(to_bt(kinematic ? b.motion(0.0) : b.pose)));
    btVector3 inertia(0, 0, 0);
    if (b.mass > 0) shape->calculateLocalInertia(btScalar(b.mass), inertia);
    btRigidBody::btRigidBodyConstructionInfo info(btScalar(b.mass), states.back().get(), shape.get(), inertia);
    info.m_friction = btScalar(b.friction);
    info.m_restitution = btScalar(b.restitution);
    auto body = std::make_unique<btRigidBody>(info);
    if (kinematic) {
      body->setCollisionFlags(body->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
      body->setActivationState(DISABLE_DEACTIVATION);
    }
    if (b.mass > 0) {
      body->setLinearVelocity(to_bt(b.velocity));
      body->setAngularVelocity(to_bt(b.angular_velocity));
    }
    world->addRigidBody(body.get());
    shapes.push_back(std::move(shape));
    bodies.push_back(std::move(body));
  }
};

}  // namespace loom::bullet
