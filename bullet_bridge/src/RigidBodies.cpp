#include "loom/bullet/RigidBodies.h"

#include <btBulletDynamicsCommon.h>

#include <string>

#include "BulletConvert.h"
#include "loom/cloth/Error.h"

namespace loom::bullet {

RigidBodies::RigidBodies(btDynamicsWorld& w) : world(&w) {}

RigidBodies::~RigidBodies() {
  for (auto& b : bodies) world->removeRigidBody(b.get());
}

btRigidBody* RigidBodies::add(std::unique_ptr<btCollisionShape> shape, double mass, const btTransform& pose,
                              bool kinematic) {
  states.push_back(std::make_unique<btDefaultMotionState>(pose));
  btVector3 inertia(0, 0, 0);
  if (mass > 0) shape->calculateLocalInertia(btScalar(mass), inertia);
  btRigidBody::btRigidBodyConstructionInfo info(btScalar(mass), states.back().get(), shape.get(), inertia);
  auto body = std::make_unique<btRigidBody>(info);
  if (kinematic) {
    body->setCollisionFlags(body->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
    body->setActivationState(DISABLE_DEACTIVATION);
  }
  world->addRigidBody(body.get());
  shapes.push_back(std::move(shape));
  bodies.push_back(std::move(body));
  return bodies.back().get();
}

btRigidBody* RigidBodies::add(const collision::RigidBodySpec& b, size_t index) {
  using collision::ShapeType;
  std::unique_ptr<btCollisionShape> shape;
  switch (b.shape.type) {
    case ShapeType::plane:
      shape = std::make_unique<btStaticPlaneShape>(btVector3(0, 1, 0), 0);
      break;
    case ShapeType::sphere:
      shape = std::make_unique<btSphereShape>(btScalar(b.shape.radius));
      break;
    case ShapeType::capsule:
      shape = std::make_unique<btCapsuleShape>(btScalar(b.shape.radius), btScalar(2 * b.shape.half_height));
      break;
    case ShapeType::box:
      shape = std::make_unique<btBoxShape>(to_bt(b.shape.half_extents));
      break;
    case ShapeType::cylinder:
      shape = std::make_unique<btCylinderShape>(
          btVector3(btScalar(b.shape.radius), btScalar(b.shape.half_height), btScalar(b.shape.radius)));
      break;
    default:
      throw Error(
          "", "bodies[" + std::to_string(index) + "].shape",
          std::string(collision::shape_type_name(b.shape.type)) + " is not supported for rigid bodies");
  }
  const bool kinematic = static_cast<bool>(b.motion);
  btRigidBody* body = add(std::move(shape), b.mass, to_bt(kinematic ? b.motion(0.0) : b.pose), kinematic);
  body->setFriction(btScalar(b.friction));
  body->setRestitution(btScalar(b.restitution));
  if (b.mass > 0) {
    body->setLinearVelocity(to_bt(b.velocity));
    body->setAngularVelocity(to_bt(b.angular_velocity));
  }
  return body;
}

}  // namespace loom::bullet
