#pragma once
// Colliders: the rigid side of collision (docs/architecture.md, "Collision"). A collider is a shape with two
// poses per step, `prev` at the step's start and `curr` at its end, so swept tests are exact for kinematic
// motion (a body's velocity within a step is what takes prev to curr). Who moves a collider:
//   - a scene's keyframed or spinning motion (`motion`, sampled by the body-collision stage each step),
//   - a character rig or a Bullet world, which write prev/curr before each step.
// Contacts push the cloth; the reaction (minus the impulse given to the cloth) is summed per collider so a
// two-way coupling (BulletCloth) can hand it back to a dynamic body.
//
// Shape conventions (all in the collider's local frame, the same axes as Bullet's default shapes):
//   plane    y = 0, normal +y, solid below (y < 0)
//   sphere   centre at the origin, `radius`
//   capsule  segment from (0, -half_height, 0) to (0, +half_height, 0), `radius`
//   box      |x| <= half_extents.x, ... (centre at the origin)
//   cylinder axis y, |y| <= half_height, `radius`
//   convex   hull of `vertices`
//   mesh     static triangle mesh `vertices` + `triangles` (two-sided, thickness only)
#include <Eigen/Geometry>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::collision {

using loom::cloth::Tri;
using loom::cloth::Vec3;
using Transform = Eigen::Isometry3d;

struct ColliderGeometry;  // ColliderGeometry.h: hull planes / FCL models for convex and mesh shapes

enum class ShapeType { plane, sphere, capsule, box, cylinder, convex, mesh };
const char* shape_type_name(ShapeType type);

struct Shape {
  ShapeType type = ShapeType::sphere;
  double radius = 0.0;               // m: sphere, capsule, cylinder
  double half_height = 0.0;          // m: capsule (half segment length), cylinder
  Vec3 half_extents = Vec3::Zero();  // m: box
  std::vector<Vec3> vertices;        // m, local: convex hull points or mesh vertices
  std::vector<Tri> triangles;        // mesh only
};

struct Collider {
  std::string name;
  Shape shape;
  Transform prev = Transform::Identity();  // pose at the step's start
  Transform curr = Transform::Identity();  // pose at the step's end
  // Scene-driven kinematic motion: pose at time t (s). Empty: static, or driven from outside (rig, Bullet).
  std::function<Transform(double)> motion;
  double friction = 0.3;         // 1, kinetic Coulomb coefficient against cloth
  double static_friction = 0.4;  // 1, static coefficient (>= friction)
  // Reaction on the collider since the owner last cleared it (two-way coupling): the sum of minus the
  // impulses given to the cloth (N s), and their moment about curr's origin (N m s).
  Vec3 reaction_impulse = Vec3::Zero();
  Vec3 reaction_angular_impulse = Vec3::Zero();
  double thickness = 0.0;  // m; contact offset for this collider (0: the body-collision stage's default)
  // Convex hull (planes, FCL Convex) or mesh BVH (FCL OBBRSS), built once by prepare_collider
  // (ColliderGeometry.h); null for the analytic shapes. Shared by copies of the collider.
  std::shared_ptr<const ColliderGeometry> geometry;
};

// The colliders of a simulation, shared by the stages that read them (body collision) and the owners that
// move them (scene motion, character rig, Bullet bridge).
using ColliderSet = std::vector<Collider>;
using ColliderSetPtr = std::shared_ptr<ColliderSet>;

}  // namespace loom::collision
