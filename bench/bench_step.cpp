// Micro-benchmarks of one solver step on the hanging cloth, so solvers and thread counts can be compared
// as ratios within one run:  build/bench/loom_bench_step --benchmark_filter=Step
#include <benchmark/benchmark.h>

#include "loom/cloth/Simulation.h"

namespace {

using namespace loom::cloth;

SimulationSetup hanging(int n, const char* method, int threads) {
  SimulationSetup s;
  ClothSetup c;
  GridSpec g;
  g.nodes_u = g.nodes_v = n;
  c.mesh = ClothMesh::grid(g);
  c.material = material_preset("cotton");
  c.material.areal_density = 0.2;
  c.pins = {PinSpec{0, {}, {}, {}}, PinSpec{n - 1, {}, {}, {}}};
  s.cloths.push_back(c);
  s.solver.method = method;
  s.substeps = 1;
  s.frame_dt = 1e-4;  // one stable explicit step per "frame"
  s.threads = threads;
  return s;
}

void run(benchmark::State& state, const char* method) {
  const int n = static_cast<int>(state.range(0)), threads = static_cast<int>(state.range(1));
  Simulation sim(hanging(n, method, threads));
  for (auto _ : state) benchmark::DoNotOptimize(sim.step_frame());
  state.counters["vertices"] = n * n;
  state.SetItemsProcessed(state.iterations() * n * n);
}

void StepSymplecticEuler(benchmark::State& s) { run(s, "symplectic_euler"); }
void StepVerlet(benchmark::State& s) { run(s, "verlet"); }
void StepExplicitEuler(benchmark::State& s) { run(s, "explicit_euler"); }

}  // namespace

BENCHMARK(StepSymplecticEuler)->ArgsProduct({{33, 65, 129}, {1, 2}})->Unit(benchmark::kMicrosecond);
BENCHMARK(StepVerlet)->ArgsProduct({{33, 65, 129}, {1, 2}})->Unit(benchmark::kMicrosecond);
BENCHMARK(StepExplicitEuler)->ArgsProduct({{33, 65, 129}, {1, 2}})->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
