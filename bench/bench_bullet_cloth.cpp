// What a Loom cloth costs in a Bullet world: ms per Bullet step (stepSimulation of one 1/240 s
// substep) of a world with a few rigid bodies (ground, 8 boxes, a sphere), without and with a BulletCloth
// action (N x N sheet, 1.2 m, implicit Euler, adaptive cloth steps: BulletClothSettings' setup tier) released
// 0.1 m above the sphere. Two phases, one second (240 Bullet steps) each, from the release:
//   phase 0 "drop":   the cloth falls, hits the sphere and boxes and drapes (the adaptive cloth steps are
//                     many while it moves fast),
//   phase 1 "draped": the second second, the cloth resting on the bodies.
// Counters: cpu_ms_per_step (process CPU time, all threads), ms_per_step (wall), cloth_steps_per_step.
// BM_ToyBox: scenes/toy_box.json (corner-tied cloth of `nodes` x `nodes`, 33 in the scene; 12 small bodies,
// a kinematic paddle) for its first `frames` 60 Hz frames, as `loom run` builds it (BulletScene) in
// BulletClothSettings' real-time tier (system 0) and as Bullet's classic btSoftBody twin with the same bodies
// (system 1, `loom compare`'s run_bullet_twin), in the same process. Counters: ms_per_frame (wall, cloth and
// world), cpu_ms_per_frame (process CPU time; the twin's includes building its world), cloth_ms_per_frame
// (system 0: the cloth pipeline alone, wall).
//
// BM_ClothOverFloor: a 33 x 33 cloth (1.2 m, implicit Euler, BulletClothSettings' setup tier: its default
// feature contacts, collision/FeatureContact.h), 60 Bullet steps after a 60-step settle; floor 0: none, 1:
// btStaticPlaneShape, 2: a 200 m btBoxShape, top at y = 0 both. place 0: tied at its four corners 1.5 m above
// the floor (out of reach: the plane, infinite, is still a broad-phase candidate); place 1: free, released
// flat 5 mm above the floor (resting on it; with no floor it falls freely). The ratio floor / no floor in one
// run is what a large static shape costs. Counters: cpu_ms_per_step, cloth_steps_per_step,
// contact_ms_per_step and contacts_per_step (FeatureContactStage's vertex contacts). Built twice from this
// file (BM_ToyBox only in the float one): loom_bench_bullet_cloth (float Bullet),
// loom_bench_bullet_cloth_double.
#include <benchmark/benchmark.h>
#include <btBulletDynamicsCommon.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>

#include "loom/bullet/BulletCloth.h"
#ifdef LOOM_BENCH_TOY_BOX
#include "loom/bullet/BulletScene.h"
#include "loom/bullet/Compare.h"
#endif
#include "loom/bullet/RigidBodies.h"
#include "loom/cloth/ClothMesh.h"
#ifdef LOOM_BENCH_TOY_BOX
#include "loom/scene/Scene.h"
#endif

namespace {

// The bridge's setup tier (the sheet's own implicit Euler, feature contacts), the one these figures measure.
loom::bullet::BulletClothSettings setup_tier() {
  loom::bullet::BulletClothSettings s;
  s.tier = loom::bullet::BulletClothSettings::Tier::setup;
  return s;
}

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
    cloth = std::make_unique<loom::bullet::BulletCloth>(s, setup_tier());
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

// The setup tier's contact stage: (ms, vertex contacts) summed since the cloth was made.
std::pair<double, double> contact_stage(const loom::bullet::BulletCloth& cloth) {
  for (const loom::cloth::StageProfile& p : cloth.simulation().profile()) {
    if (p.name != "feature_contact") continue;
    double n = 0.0;
    for (const auto& c : p.counters)
      if (c.first == "vertex_contacts") n = c.second;
    return {p.total_ms, n};
  }
  return {0.0, 0.0};
}

void BM_ClothOverFloor(benchmark::State& state) {
  const int floor = static_cast<int>(state.range(0));
  const bool resting = state.range(1) == 1;
  constexpr int kN = 33, kSettle = 60, kSteps = 60;
  double cpu = 0.0, contact_ms = 0.0, contacts = 0.0;
  long cloth_steps = 0, bullet_steps = 0;
  for (auto _ : state) {
    state.PauseTiming();
    auto w = std::make_unique<World>(0);  // ground plane, boxes and sphere: removed below
    for (int k = w->world.getNumCollisionObjects() - 1; k >= 0; --k)
      w->world.removeCollisionObject(w->world.getCollisionObjectArray()[k]);
    if (floor == 1)
      w->add(std::make_unique<btStaticPlaneShape>(btVector3(0, 1, 0), 0), 0, btVector3(0, 0, 0));
    if (floor == 2) w->add(std::make_unique<btBoxShape>(btVector3(100, 100, 100)), 0, btVector3(0, -100, 0));
    loom::cloth::SimulationSetup s;
    s.solver.method = "implicit_euler";
    loom::cloth::ClothSetup c;
    loom::cloth::GridSpec g;
    g.nodes_u = g.nodes_v = kN;
    g.size_u = g.size_v = 1.2;
    g.origin = loom::cloth::Vec3(-0.6, resting ? 0.005 : 1.5, -0.6);
    c.mesh = loom::cloth::ClothMesh::grid(g);
    c.material.damping = 0.001;
    if (!resting)
      for (int corner : {0, kN - 1, kN * (kN - 1), kN * kN - 1})
        c.pins.push_back(loom::cloth::PinSpec{corner, {}, {}, {}});
    s.cloths.push_back(c);
    w->cloth = std::make_unique<loom::bullet::BulletCloth>(s, setup_tier());
    w->cloth->add_to(&w->world);
    for (int k = 0; k < kSettle; ++k) w->step();
    const long c0 = w->cloth->cloth_steps();
    const auto s0 = contact_stage(*w->cloth);
    state.ResumeTiming();
    const double cpu0 = process_cpu_s();
    for (int k = 0; k < kSteps; ++k) w->step();
    cpu += process_cpu_s() - cpu0;
    cloth_steps += w->cloth->cloth_steps() - c0;
    const auto s1 = contact_stage(*w->cloth);
    contact_ms += s1.first - s0.first;
    contacts += s1.second - s0.second;
    bullet_steps += kSteps;
    state.PauseTiming();
    w.reset();
    state.ResumeTiming();
  }
  state.counters["cpu_ms_per_step"] = 1e3 * cpu / double(bullet_steps);
  state.counters["cloth_steps_per_step"] = double(cloth_steps) / double(bullet_steps);
  state.counters["contact_ms_per_step"] = contact_ms / double(bullet_steps);
  state.counters["contacts_per_step"] = contacts / double(bullet_steps);
  state.SetLabel(std::string(floor == 0   ? "no floor"
                             : floor == 1 ? "static plane"
                                          : "static 200 m box") +
                 (resting ? ", cloth resting" : ", cloth tied above"));
}
BENCHMARK(BM_ClothOverFloor)
    ->ArgNames({"floor", "place"})
    ->ArgsProduct({{0, 1, 2}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime();

#ifdef LOOM_BENCH_TOY_BOX
void BM_ToyBox(benchmark::State& state) {
  const int system = static_cast<int>(state.range(0));
  const int frames = static_cast<int>(state.range(1));
  const int nodes = static_cast<int>(state.range(2));
  const loom::scene::Scene sc = loom::scene::load_scene(
      std::string(LOOM_SOURCE_DIR) + "/scenes/toy_box.json",
      {"cloths.0.mesh.nodes=[" + std::to_string(nodes) + "," + std::to_string(nodes) + "]"});
  double ms = 0.0, cloth_ms = 0.0, cpu_s = 0.0, max_strain = 0.0;
  long runs = 0;
  for (auto _ : state) {
    if (system == 0) {
      state.PauseTiming();
      loom::bullet::BulletSceneOptions options;
      options.realtime = true;
      auto bs = std::make_unique<loom::bullet::BulletScene>(sc.setup, sc.bodies, options);
      state.ResumeTiming();
      const double cpu0 = process_cpu_s();
      const auto wall0 = std::chrono::steady_clock::now();
      for (int f = 0; f < frames; ++f) {
        const loom::cloth::FrameStats st = bs->step_frame();
        cloth_ms += st.total_ms;
        max_strain = std::max(max_strain, st.max_strain);
      }
      ms += 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
      cpu_s += process_cpu_s() - cpu0;
      state.PauseTiming();
      bs.reset();
      state.ResumeTiming();
    } else {
      loom::bullet::CompareInput in;
      in.setup = sc.setup;
      in.bodies = sc.bodies;
      in.frames = frames;
      const double cpu0 = process_cpu_s();
      const loom::bullet::SystemMetrics m =
          loom::bullet::run_bullet_twin(in, loom::bullet::TwinKind::kClassic);
      cpu_s += process_cpu_s() - cpu0;
      ms += m.ms_per_frame * frames;
      state.counters["max_strain"] = m.max_strain;
      state.counters["max_penetration_mm"] = 1e3 * m.max_penetration;
    }
    ++runs;
  }
  state.counters["ms_per_frame"] = ms / double(runs * frames);
  state.counters["cpu_ms_per_frame"] = 1e3 * cpu_s / double(runs * frames);
  if (system == 0) {
    state.counters["cloth_ms_per_frame"] = cloth_ms / double(runs * frames);
    state.counters["max_strain"] = max_strain;
  }
  state.SetLabel(system == 0 ? "Loom BulletCloth, real-time tier" : "Bullet classic btSoftBody twin");
}
BENCHMARK(BM_ToyBox)
    ->ArgNames({"system", "frames", "nodes"})
    ->ArgsProduct({{0, 1}, {60}, {33, 17}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
#endif

}  // namespace

BENCHMARK_MAIN();
