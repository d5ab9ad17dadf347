// What a Loom cloth costs in a Bullet world (issue 9): ms per Bullet step (stepSimulation of one 1/240 s
// substep) of a world with a few rigid bodies, without and with a BulletCloth action (N x N sheet, implicit
// Euler, one cloth step per Bullet step) draped over them.
#include <benchmark/benchmark.h>
#include <btBulletDynamicsCommon.h>

#include <memory>
#include <vector>

#include "loom/bullet/BulletCloth.h"
#include "loom/cloth/ClothMesh.h"

namespace {

struct World {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btDefaultMotionState>> states;
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  std::unique_ptr<loom::bullet::BulletCloth> cloth;

  World(int n, bool with_cloth) {
    world.setGravity(btVector3(0, -9.81, 0));
    add(new btStaticPlaneShape(btVector3(0, 1, 0), 0), 0, btVector3(0, 0, 0));
    for (int k = 0; k < 8; ++k) add(new btBoxShape(btVector3(0.1, 0.1, 0.1)), 1.0, btVector3(-0.35 + 0.1 * k, 0.1, 0.1 * (k % 3)));
    add(new btSphereShape(0.2), 2.0, btVector3(0, 0.4, -0.2));
    if (!with_cloth) return;
    loom::cloth::SimulationSetup s;
    s.solver.method = "implicit_euler";
    loom::cloth::ClothSetup c;
    loom::cloth::GridSpec g;
    g.nodes_u = g.nodes_v = n;
    g.size_u = g.size_v = 1.2;
    g.origin = loom::cloth::Vec3(-0.6, 0.7, -0.6);
    c.mesh = loom::cloth::ClothMesh::grid(g);
    c.material.damping = 0.001;
    s.cloths.push_back(c);
    loom::bullet::BulletClothSettings bs;
    cloth = std::make_unique<loom::bullet::BulletCloth>(s, bs);
    cloth->add_to(&world);
  }
  ~World() {
    if (cloth) cloth->remove_from(&world);
    for (auto& b : bodies) world.removeRigidBody(b.get());
  }
  void add(btCollisionShape* shape, double mass, const btVector3& p) {
    shapes.emplace_back(shape);
    btTransform tf;
    tf.setIdentity();
    tf.setOrigin(p);
    states.push_back(std::make_unique<btDefaultMotionState>(tf));
    btVector3 inertia(0, 0, 0);
    if (mass > 0) shape->calculateLocalInertia(btScalar(mass), inertia);
    bodies.push_back(std::make_unique<btRigidBody>(btRigidBody::btRigidBodyConstructionInfo(btScalar(mass), states.back().get(), shape, inertia)));
    world.addRigidBody(bodies.back().get());
  }
};

void BM_BulletStep(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  World w(n, n > 0);
  for (int k = 0; k < 60; ++k) w.world.stepSimulation(btScalar(1.0 / 240), 1, btScalar(1.0 / 240));  // settle onto the bodies
  for (auto _ : state) w.world.stepSimulation(btScalar(1.0 / 240), 1, btScalar(1.0 / 240));
  state.counters["cloth_nodes"] = n * n;
  state.SetLabel(n > 0 ? "with cloth action" : "rigid bodies only");
}
BENCHMARK(BM_BulletStep)->Arg(0)->Arg(17)->Arg(33)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
