// What a Loom cloth costs in a Bullet world (issue 9): ms per Bullet step (stepSimulation of one 1/240 s
// substep) of a world with a few rigid bodies, without and with a BulletCloth action (N x N sheet, implicit
// Euler, adaptive cloth steps: BulletClothSettings' defaults) draped over them. Built twice from this file:
// loom_bench_bullet_cloth (float Bullet) and loom_bench_bullet_cloth_double (double Bullet).
#include <benchmark/benchmark.h>
#include <btBulletDynamicsCommon.h>

#include <memory>
#include <string>

#include "loom/bullet/BulletCloth.h"
#include "loom/bullet/RigidBodies.h"
#include "loom/cloth/ClothMesh.h"

namespace {

struct World {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  loom::bullet::RigidBodies rigid{world};
  std::unique_ptr<loom::bullet::BulletCloth> cloth;

  // Ground, 8 boxes and a sphere; with n > 0 an n x n cloth (1.2 m) above them.
  explicit World(int n) {
    world.setGravity(btVector3(0, -9.81, 0));
    add(std::make_unique<btStaticPlaneShape>(btVector3(0, 1, 0), 0), 0, btVector3(0, 0, 0));
    for (int k = 0; k < 8; ++k)
      add(std::make_unique<btBoxShape>(btVector3(0.1, 0.1, 0.1)), 1.0, btVector3(btScalar(-0.35 + 0.1 * k), 0.1, btScalar(0.1 * (k % 3))));
    add(std::make_unique<btSphereShape>(0.2), 2.0, btVector3(0, 0.4, -0.2));
    if (n <= 0) return;
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
    cloth = std::make_unique<loom::bullet::BulletCloth>(s, loom::bullet::BulletClothSettings{});
    cloth->add_to(&world);
  }
  ~World() {
    if (cloth) cloth->remove_from(&world);
  }
  void add(std::unique_ptr<btCollisionShape> shape, double mass, const btVector3& p) {
    btTransform tf;
    tf.setIdentity();
    tf.setOrigin(p);
    rigid.add(std::move(shape), mass, tf);
  }
  void step() { world.stepSimulation(btScalar(1.0 / 240), 1, btScalar(1.0 / 240)); }
};

void BM_BulletStep(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  World w(n);
  for (int k = 0; k < 60; ++k) w.step();  // settle onto the bodies
  const long steps0 = w.cloth ? w.cloth->cloth_steps() : 0;
  long bullet_steps = 0;
  for (auto _ : state) {
    w.step();
    ++bullet_steps;
  }
  state.counters["cloth_nodes"] = n * n;
  state.counters["cloth_steps_per_step"] = w.cloth ? double(w.cloth->cloth_steps() - steps0) / double(bullet_steps) : 0.0;
  state.SetLabel(std::string(sizeof(btScalar) == 8 ? "double" : "float") +
                 (n > 0 ? " Bullet, with cloth action" : " Bullet, rigid bodies only"));
}
BENCHMARK(BM_BulletStep)->Arg(0)->Arg(17)->Arg(33)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
