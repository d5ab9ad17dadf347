#pragma once
// A small Bullet world for the BulletCloth tests: btDiscreteDynamicsWorld with the default configuration,
// its bodies (bullet::RigidBodies) and cloths, and sheet set-ups.
#include <btBulletDynamicsCommon.h>

#include <memory>
#include <vector>

#include "SymplecticSetup.h"
#include "loom/bullet/BulletCloth.h"
#include "loom/bullet/RigidBodies.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Simulation.h"

namespace loom::test {

using cloth::Vec3;

inline btVector3 bt(const Vec3& v) { return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z())); }
inline Vec3 eig(const btVector3& v) { return Vec3(v.x(), v.y(), v.z()); }

// The bridge's setup tier (the SimulationSetup's own solver, feature contacts, reactions after the step), for
// the tests that validate it; BulletClothSettings' default is the real-time (coupled) tier.
inline bullet::BulletClothSettings setup_tier() {
  bullet::BulletClothSettings s;
  s.tier = bullet::BulletClothSettings::Tier::setup;
  return s;
}

struct TestWorld {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  bullet::RigidBodies rigid{world};  // after the world: its bodies leave the world first
  std::vector<std::unique_ptr<bullet::BulletCloth>> cloths;

  explicit TestWorld(const Vec3& g = Vec3(0, -9.81, 0)) { world.setGravity(bt(g)); }
  ~TestWorld() {
    for (auto& c : cloths) c->remove_from(&world);
  }

  // mass 0: static; kinematic: mass 0 + CF_KINEMATIC_OBJECT (moved through its motion state).
  btRigidBody* add_body(btCollisionShape* shape, double mass, const Vec3& pos, bool kinematic = false) {
    btTransform tf;
    tf.setIdentity();
    tf.setOrigin(bt(pos));
    return rigid.add(std::unique_ptr<btCollisionShape>(shape), mass, tf, kinematic);
  }

  bullet::BulletCloth* add_cloth(cloth::SimulationSetup setup, const bullet::BulletClothSettings& s) {
    cloths.push_back(std::make_unique<bullet::BulletCloth>(std::move(setup), s));
    cloths.back()->add_to(&world);
    return cloths.back().get();
  }

  // One 1/60 s frame in 1/240 s substeps.
  void frame(double frame_dt = 1.0 / 60.0, double fixed = 1.0 / 240.0) {
    world.stepSimulation(btScalar(frame_dt), 10, btScalar(fixed));
  }
};

// A soft test fabric (500 N/m, 0.3 kg/m²) on an n x n grid of side `size` in the xz plane, node (0,0) at
// `origin`; symplectic Euler.
inline cloth::SimulationSetup sheet(int n, double size, const Vec3& origin,
                                    const Vec3& gravity = Vec3(0, -9.81, 0)) {
  cloth::SimulationSetup s = loom::test::symplectic_setup();
  s.gravity = gravity;
  s.solver.method = "symplectic_euler";
  cloth::ClothSetup c;
  cloth::GridSpec g;
  g.nodes_u = g.nodes_v = n;
  g.size_u = g.size_v = size;
  g.origin = origin;
  c.mesh = cloth::ClothMesh::grid(g);
  c.material.stretch_weft = c.material.stretch_warp = 500.0;
  c.material.shear = 50.0;
  c.material.areal_density = 0.3;
  c.material.damping = 1e-3;
  s.cloths.push_back(c);
  return s;
}

}  // namespace loom::test
