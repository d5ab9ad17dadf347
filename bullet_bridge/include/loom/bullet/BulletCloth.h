#pragma once
// BulletCloth: a Loom cloth living in a Bullet world, coupled both ways (docs/architecture.md, "Bullet";
// docs/bullet.md). Add it to any btDynamicsWorld (btDiscreteDynamicsWorld, btSoftRigidDynamicsWorld,
// btDeformableMultiBodyDynamicsWorld) with add_to(world). Each Bullet substep (updateAction, after
// integrateTransforms) it
//   1. queries the broad phase for rigid bodies overlapping its AABB (inflated by query_margin),
//   2. maps each body's shape to Loom colliders (map_shape) with prev = pose at the substep's start and
//      curr = pose at its end (kinematic bodies: interpolated across the substeps of one stepSimulation call,
//      which Bullet itself does not do),
//   3. steps the cloth (cloth_substeps pipeline steps of fixed_dt / cloth_substeps) with body collision and
//      attachments, then
//   4. applies the summed reaction impulse of each dynamic body (applyCentralImpulse + applyTorqueImpulse of
//      the moment about its centre of mass) and activate()s it.
// The cloth is also a collision object of the world (CO_USER_TYPE, AABB kept current, no contact response,
// collision mask 0 so it makes no pairs) so broad-phase queries see it; ray_test picks it.
// This is the one bridge header that names Bullet types: include it only from code linking loom::bullet.
#include <BulletDynamics/Dynamics/btActionInterface.h>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "loom/bullet/ClothRay.h"
#include "loom/cloth/Simulation.h"
#include "loom/collision/Collider.h"

class btCollisionObject;
class btCollisionShape;
class btDynamicsWorld;
class btRigidBody;
class btCollisionWorld;
class btIDebugDraw;

namespace loom::bullet {
class BodyCoupling;
}  // namespace loom::bullet
namespace loom::collision {
class BodyCollisionStage;
class FeatureContactStage;
}  // namespace loom::collision
namespace loom::bullet {

struct BulletClothSettings {
  double fixed_dt = 1.0 / 240.0;  // s, the world's fixedTimeStep; updateAction checks it
  int cloth_substeps = 1;         // cloth pipeline steps per Bullet substep (at least)
  double thickness = 0.005;       // m, contact offset from collider surfaces (at least the material's)
  double query_margin = 0.1;      // m, inflation of the cloth AABB for the broad-phase query

  // Quality tier of the cloth.
  //   setup: the SimulationSetup's own solver, substeps and strain limit, as given; the bodies are
  //     kinematic inside the cloth step and receive the summed reaction impulse after it (`contacts`).
  //   realtime (default): cloth and the dynamic bodies near it
  //     solved together in small XPBD steps (the bridge's BodyCoupling.h; docs/bullet.md, "Coupled
  //     solve"): contacts corrected with the generalized inverse masses of vertex and body, tethers and
  //     edges held to 1 + max_stretch of their rest length, a vertex pressed into a body moving the body
  //     with it; the bodies' new poses and velocities are handed back to Bullet. The solver and the strain
  //     limit below replace setup.solver and setup.strain_limit, and `contacts` is not used.
  enum class Tier { setup, realtime };
  Tier tier = Tier::realtime;
  std::string realtime_solver = "xpbd";  // realtime: any of cloth::solver_names() taking `iterations`
  int realtime_iterations = 1;           // realtime: solver iterations per cloth step
  int realtime_substeps = 2;             // realtime: cloth steps per Bullet substep, at least
  int coupling_iterations = 3;           // realtime: contact, tether and edge sweeps per cloth step
  int tether_anchors = 4;                // realtime: pinned vertices each vertex is tethered to (0: none)
  double max_stretch = 0.1;              // 1, realtime: strain limit l/L - 1 of edges
  double tether_stretch = 0.015;         // 1, realtime: tethers at most (1 + this) x their rest distance

  // Adaptive cloth steps: a Bullet substep runs n = ceil(relative motion / (step_motion * thickness)) cloth
  // steps, cloth_substeps <= n <= max_cloth_substeps, where the relative motion (m) is the farthest any point
  // of a nearby body moves in the substep plus the fastest cloth vertex's v dt; nearby: its colliders come
  // within both motions, the thickness and query_margin of the cloth's box (with none nearby, n =
  // cloth_substeps: a ground plane far under the cloth adds no steps). Vertex contacts are found by
  // proximity after each step, so a body must not move deeper than the contact offset per step: a body that
  // moves farther leaves vertices nearer its side than its face, and they are pushed out sideways.
  double step_motion = 0.5;  // 1, relative motion per cloth step in thicknesses
  int max_cloth_substeps = 16;
  double friction = 0.3;         // 1, kinetic Coulomb coefficient cloth vs bodies
  double static_friction = 0.4;  // 1, static coefficient (>= friction)
  // Contact response of Tier::setup, from the collision library (the bridge has no contact code of its own):
  //   features (default): collision/FeatureContact.h, cloth vertices against collider surfaces and collider
  //     features (corners, edges, capsule axes, sphere centres) against cloth triangles, so a small box
  //     corner or a capsule's end cannot pass through a triangle between its vertices; the one the bridge
  //     tests validate (tests/bullet: the scenes, the floor, the corner-first drops);
  //   body_collision: the collision library's BodyCollisionStage (CCD + proximity + cloth edges, the
  //     characters' reference tier), the exact option for vertices: no vertex crosses a collider surface
  //     within a step, whatever the speed; it has no collider-corner-against-triangle phase and is not
  //     validated on the scenes (docs/bullet.md);
  //   vertex: FeatureContactStage with its face phase off (FeatureContactSettings::faces), cloth vertices
  //     only: a collider corner or edge can pass between vertices. For comparison only.
  enum class Contacts { features, body_collision, vertex };
  Contacts contacts = Contacts::features;
};

// Colliders for one Bullet shape placed at `pose` (world frame of the shape: body transform times compound
// child transforms). Supported: sphere, capsule X/Y/Z, box, cylinder X/Y/Z, cone X/Y/Z (as convex),
// static plane, convex hull, compound (recursive, one collider per leaf child), btBvhTriangleMeshShape
// (as mesh). Any other shape appends its getName() to `unsupported` and adds no collider. Collider names are
// `name` (plus "/<child index>" per compound level).
void map_shape(const btCollisionShape* shape, const collision::Transform& pose, const std::string& name,
               std::vector<collision::Collider>& out, std::vector<std::string>& unsupported);

class BulletCloth : public btActionInterface {
 public:
  // setup.frame_dt and setup.substeps are replaced by settings.fixed_dt and settings.cloth_substeps; with
  // setup.substeps 0 (the default) a solver whose own step is shorter (fast_xpbd's 1/720 s: 3 steps per
  // 1/240 s) takes that many steps per Bullet substep (cloth::default_substeps).
  // Throws loom::Error for bad settings.
  BulletCloth(cloth::SimulationSetup setup, const BulletClothSettings& settings);
  ~BulletCloth() override;
  BulletCloth(const BulletCloth&) = delete;
  BulletCloth& operator=(const BulletCloth&) = delete;

  // addAction + addCollisionObject (and the reverse). The cloth must be removed before the world dies.
  void add_to(btDynamicsWorld* world);
  void remove_from(btDynamicsWorld* world);

  // Attaches vertex `vertex` of cloth `cloth` to `body` at its current position (stored as a body-local
  // offset): the vertex follows the body (kinematic in the cloth) and the force the cloth exerts on it is
  // applied to the body (dynamic bodies only). Throws loom::Error for an out-of-range vertex.
  void attach(int cloth, int vertex, btRigidBody* body);

  // btActionInterface
  void updateAction(btCollisionWorld* world, btScalar dt) override;
  void debugDraw(btIDebugDraw* drawer) override;

  // The nearest cloth triangle hit by the segment from -> to (ClothRay.h); exact, BVH accelerated.
  RayHit ray_test(const Vec3& from, const Vec3& to) const;

  cloth::Simulation& simulation() { return *sim_; }
  const cloth::Simulation& simulation() const { return *sim_; }
  btCollisionObject* collision_object() { return object_.get(); }
  // Colliders of the last substep (world frame) and the body each came from (nullptr: none).
  const collision::ColliderSet& colliders() const { return *colliders_; }
  // Unsupported shape names, each once, in the order met; the callback (if set) is called once per name.
  const std::vector<std::string>& warnings() const { return warnings_; }
  void set_warning_callback(std::function<void(const std::string&)> cb) { warn_ = std::move(cb); }
  // Summed impulse (N s) the cloth applied to `body` since construction (contacts + attachments).
  Vec3 applied_impulse(const btRigidBody* body) const;
  // Largest penetration (m) of a cloth vertex into a collider seen (before push-out) in the last substep.
  double last_penetration() const { return last_penetration_; }
  long substeps() const { return substeps_; }        // Bullet substeps run
  long cloth_steps() const { return cloth_steps_; }  // cloth pipeline steps run (adaptive, see settings)
  // Cloth pipeline steps per Bullet substep before the adaptive ones: cloth_substeps, or in Tier::realtime
  // the larger of it and realtime_substeps (at most max_cloth_substeps more are taken near a moving body).
  int min_cloth_steps() const;
  // The cloth simulation's statistics for the last Bullet substep (Simulation::step_frame).
  const cloth::FrameStats& last_stats() const { return last_stats_; }
  // Pose of `body` that the cloth used at the end of the last substep (interpolated for kinematic bodies).
  collision::Transform body_pose(const btRigidBody* body) const;

  struct Attachment {
    int cloth = 0, vertex = 0;
    btRigidBody* body = nullptr;
    Vec3 offset = Vec3::Zero();  // m, body-local
  };
  const std::vector<Attachment>& attachments() const { return attachments_; }

 private:
  struct BodyTrack;
  class PoseStage;
  class AttachStage;
  class ReactionStage;
  void update_aabb();
  void cloth_aabb(Vec3& lo, Vec3& hi) const;
  double contacts_thickness() const;
  void warn(const std::string& shape_name);
  BodyTrack& track(btRigidBody* body);
  // Rigid bodies overlapping the inflated cloth AABB, plus attached bodies; unique, ordered by proxy id.
  std::vector<btRigidBody*> candidate_bodies(btCollisionWorld* world);
  // The body's pose at the substep's start and end (tr.start, tr.end) for a substep of dt (s).
  void advance_pose(BodyTrack& tr, btRigidBody* rb, double dt);
  // Maps the body's collision shape to colliders in its frame (tr.local) when the shape changed.
  void map_body_shape(BodyTrack& tr, btRigidBody* rb);
  // Tier::realtime: enters a dynamic, unattached body into the coupled solve (appended to `coupled`);
  // returns its index there, -1 if it is not coupled.
  int add_coupled_body(const BodyTrack& tr, btRigidBody* rb, std::vector<btRigidBody*>& coupled);
  // Poses of `bodies` over a substep of dt (s) and their colliders (colliders_, collider_body_,
  // collider_local_ and the coupling's per-collider lists).
  void make_colliders(const std::vector<btRigidBody*>& bodies, double dt, std::vector<btRigidBody*>& coupled);
  // Cloth steps for a substep of dt (s): the settings' count, raised until no collider point nor cloth
  // vertex moves more than step_motion thicknesses per step (at most max_cloth_substeps).
  int cloth_step_count(const std::vector<btRigidBody*>& bodies, double dt) const;
  // Tier::realtime: the touched coupled bodies take the coupled solve's pose and velocities.
  void apply_coupled_solve(const std::vector<btRigidBody*>& coupled);
  // The colliders' reaction impulses and moments, applied to the dynamic bodies.
  void apply_reactions(const std::vector<btRigidBody*>& bodies);

  BulletClothSettings settings_;
  std::unique_ptr<cloth::Simulation> sim_;
  collision::ColliderSetPtr colliders_;
  std::vector<btRigidBody*> collider_body_;           // per collider
  std::vector<collision::Transform> collider_local_;  // per collider: shape pose in the body frame
  std::vector<Attachment> attachments_;
  std::map<const btRigidBody*, std::unique_ptr<BodyTrack>> tracks_;
  std::unique_ptr<btCollisionShape> aabb_shape_;
  std::unique_ptr<btCollisionObject> object_;
  btDynamicsWorld* world_ = nullptr;
  std::vector<std::string> warnings_;
  std::function<void(const std::string&)> warn_;
  collision::FeatureContactStage* features_ = nullptr;  // owned by sim_ (Contacts::features, vertex)
  collision::BodyCollisionStage* body_ = nullptr;       // owned by sim_ (Contacts::body_collision)
  std::unique_ptr<BodyCoupling> coupling_;              // Tier::realtime
  double thickness_ = 0.0;                              // m, the contact thickness in use
  double substep_t0_ = 0.0;                             // s, cloth time at the current Bullet substep's start
  double last_penetration_ = 0.0;
  long substeps_ = 0;
  long cloth_steps_ = 0;
  cloth::FrameStats last_stats_;
  mutable std::vector<std::unique_ptr<ClothRayCaster>> casters_;  // per cloth, for ray_test
};

}  // namespace loom::bullet
