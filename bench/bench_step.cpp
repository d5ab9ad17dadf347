// Micro-benchmarks of one solver step on the hanging cloth, so solvers and thread counts can be compared
// as ratios within one run:  build/bench/loom_bench_step --benchmark_filter=Step
// The global solve of projective dynamics and desbrun (three right-hand sides with the prefactorised
// M + h² L_k + h L_c), SplitCholesky against Eigen's SimplicialLLT:  --benchmark_filter=GlobalSolve
#include <benchmark/benchmark.h>

#include <Eigen/SparseCholesky>
#include <random>

#include "loom/cloth/Simulation.h"
#include "loom/cloth/SplitCholesky.h"
#include "loom/cloth/SpringSolverSupport.h"

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
void StepPbd(benchmark::State& s) { run(s, "pbd"); }
void StepXpbd(benchmark::State& s) { run(s, "xpbd"); }

// The hanging cloth's global matrix at a 60 Hz step, and three random right-hand sides.
struct GlobalSystem {
  Eigen::SparseMatrix<double> a;
  Eigen::MatrixX3d b;
  explicit GlobalSystem(int n) {
    Simulation sim(hanging(n, "symplectic_euler", 1));
    const Cloth& cloth = *sim.cloths()[0];
    int nf = 0;
    const std::vector<int> index = free_index(cloth.state(), &nf);
    const double h = 1.0 / 60.0;
    a = spring_system_matrix(cloth.state(), index, nf, collect_springs(cloth), h * h, h);
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    b.resize(nf, 3);
    for (int i = 0; i < nf; ++i)
      for (int c = 0; c < 3; ++c) b(i, c) = u(rng);
  }
};

void GlobalSolveEigen(benchmark::State& state) {
  const GlobalSystem sys(static_cast<int>(state.range(0)));
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt(sys.a);
  Eigen::MatrixX3d x;
  for (auto _ : state) {
    x = llt.solve(sys.b);
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["vertices"] = static_cast<double>(sys.a.rows());
}

void GlobalSolveSplit(benchmark::State& state) {
  const GlobalSystem sys(static_cast<int>(state.range(0)));
  SplitCholesky factor;
  if (!factor.compute(sys.a)) state.SkipWithError(factor.error().c_str());
  Eigen::MatrixX3d x;
  for (auto _ : state) {
    factor.solve(sys.b, x, static_cast<int>(state.range(1)));
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["vertices"] = static_cast<double>(sys.a.rows());
  state.counters["separator"] = factor.part_sizes()[2];
}

}  // namespace

BENCHMARK(GlobalSolveEigen)->Arg(65)->Arg(129)->Unit(benchmark::kMicrosecond);
BENCHMARK(GlobalSolveSplit)->ArgsProduct({{65, 129}, {1, 2}})->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(StepSymplecticEuler)->ArgsProduct({{33, 65, 129}, {1, 2}})->Unit(benchmark::kMicrosecond);
BENCHMARK(StepVerlet)->ArgsProduct({{33, 65, 129}, {1, 2}})->Unit(benchmark::kMicrosecond);
BENCHMARK(StepExplicitEuler)->ArgsProduct({{33, 65, 129}, {1, 2}})->Unit(benchmark::kMicrosecond);
BENCHMARK(StepPbd)->ArgsProduct({{65, 129}, {1, 2}})->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(StepXpbd)->ArgsProduct({{65, 129}, {1, 2}})->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK_MAIN();
