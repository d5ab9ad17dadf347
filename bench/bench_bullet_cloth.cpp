// What a Loom cloth costs in a Bullet world: ms per Bullet step (stepSimulation of one 1/240 s
// substep) of a world with a few rigid bodies (ground, 8 boxes, a sphere), without and with a BulletCloth
// action (N x N sheet, 1.2 m, implicit Euler, adaptive cloth steps: BulletClothSettings' defaults) released
// 0.1 m above the sphere. Two phases, one second (240 Bullet steps) each, from the release:
//   phase 0 "drop":   the cloth falls, hits the sphere and boxes and drapes (the adaptive cloth steps are
//                     many while it moves fast),
//   phase 1 "draped": the second second, the cloth resting on the bodies.
// Counters: cpu_ms_per_step (process CPU time, all threads), ms_per_step (wall), cloth_steps_per_step.
// Built twice from this file: loom_bench_bullet_cloth (float Bullet), loom_bench_bullet_cloth_double.
#include <benchmark/benchmark.h>
#include <btBulletDynamicsCommon.h>
#include <time.h>

#include <chrono>
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
      add(std::make_unique<btBoxShape>(btVector3(0.1, 0.1, 0.1)), 1.0,
          btVector3(btScalar(-0.35 + 0.1 * k), 0.1, btScalar(0.1 * (k % 3))));
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

double process_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

void BM_BulletStep(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int phase = static_cast<int>(state.range(1));
  constexpr int kSteps = 240;  // one second
  double cpu = 0.0, wall = 0.0;
  long cloth_steps = 0, bullet_steps = 0;
  for (auto _ : state) {
    state.PauseTiming();
    auto w = std::make_unique<World>(n);
    for (int k = 0; k < phase * kSteps; ++k) w->step();
    const long c0 = w->cloth ? w->cloth->cloth_steps() : 0;
    state.ResumeTiming();
    const double cpu0 = process_cpu_s();
    const auto wall0 = std::chrono::steady_clock::now();
    for (int k = 0; k < kSteps; ++k) w->step();
    wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    cpu += process_cpu_s() - cpu0;
    cloth_steps += w->cloth ? w->cloth->cloth_steps() - c0 : 0;
    bullet_steps += kSteps;
    state.PauseTiming();  // not the world's destruction
    w.reset();
    state.ResumeTiming();
  }
  state.counters["cloth_nodes"] = n * n;
  state.counters["cpu_ms_per_step"] = 1e3 * cpu / double(bullet_steps);
  state.counters["ms_per_step"] = 1e3 * wall / double(bullet_steps);
  state.counters["cloth_steps_per_step"] = double(cloth_steps) / double(bullet_steps);
  state.SetLabel(std::string(sizeof(btScalar) == 8 ? "double" : "float") + " Bullet, " +
                 (n > 0 ? "with cloth action" : "rigid bodies only") + (phase == 0 ? ", drop" : ", draped"));
}
BENCHMARK(BM_BulletStep)
    ->ArgNames({"N", "phase"})
    ->ArgsProduct({{0, 17, 33}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime();

}  // namespace

BENCHMARK_MAIN();
