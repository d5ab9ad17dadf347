#pragma once
// RigidBodySpec: a rigid body of a scene's `bodies` array, as plain data — no Bullet types, so
// loom::scene can hold it; the Bullet bridge (loom::bullet) turns it into a btRigidBody.
#include <functional>
#include <string>
#include <vector>

#include "loom/collision/Collider.h"

namespace loom::collision {

struct BodyAttachment {
  int cloth = 0;   // index of the cloth in the scene
  int vertex = 0;  // vertex of that cloth, attached at its start position (body-local offset)
};

struct RigidBodySpec {
  std::string name;
  Shape shape;                             // plane, sphere, capsule, box or cylinder (Collider.h conventions)
  double mass = 0.0;                       // kg; 0 = static (or kinematic with `motion`)
  Transform pose = Transform::Identity();  // pose at t = 0
  Vec3 velocity = Vec3::Zero();            // m/s, dynamic bodies at t = 0
  Vec3 angular_velocity = Vec3::Zero();    // rad/s
  double friction = 0.5;                   // 1, Bullet's rigid-rigid friction
  double restitution = 0.0;                // 1
  std::function<Transform(double)> motion;  // kinematic: pose at time t (s); empty: static or dynamic
  std::vector<BodyAttachment> attachments;  // cloth vertices held by this body
};

}  // namespace loom::collision
