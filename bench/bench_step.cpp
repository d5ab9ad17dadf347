// Micro-benchmarks of one solver step on the hanging cloth, so solvers and thread counts can be compared
// as ratios within one run:  build/bench/loom_bench_step --benchmark_filter=Step
// The global solve of projective dynamics and desbrun (three right-hand sides with the prefactorised
// M + h² L_k + h L_c), SplitCholesky against Eigen's SimplicialLLT:  --benchmark_filter=GlobalSolve
#include <benchmark/benchmark.h>

#include <Eigen/SparseCholesky>
#include <cmath>
#include <map>
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

// The frame's pipeline time as the accuracy bench counts it: the top-level stages without "stats" (ms).
double pipeline_ms(const std::vector<std::string>& names, const FrameStats& fs) {
  double ms = 0.0;
  for (size_t k = 0; k < names.size() && k < fs.stage_ms.size(); ++k)
    if (names[k].find('/') == std::string::npos && names[k] != "stats") ms += fs.stage_ms[k];
  return ms;
}

// Manual time: each frame's pipeline time (pipeline_ms), so the serial statistics pass is not counted.
void run(benchmark::State& state, const char* method) {
  const int n = static_cast<int>(state.range(0)), threads = static_cast<int>(state.range(1));
  SimulationSetup setup = hanging(n, method, threads);
  if (state.range(2) > 0) setup.solver.params["iterations"] = static_cast<double>(state.range(2));
  if (state.range(3) > 0) {
    // The accuracy bench's frames: 1/60 s in that many substeps.
    setup.frame_dt = 1.0 / 60.0;
    setup.substeps = static_cast<int>(state.range(3));
  }
  Simulation sim(setup);
  const std::vector<std::string> names = sim.stage_names();
  for (auto _ : state) state.SetIterationTime(1e-3 * pipeline_ms(names, sim.step_frame()));
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

// The accuracy bench's first 0.25 s (15 frames of 1/60 s) of the hanging cloth, horizontal at the start with
// its 1 mm bump, under backward Euler at the fastest configuration within the accuracy bench's strain target
// (one substep, multigrid 1, CG tolerance 0.02, at most 10 iterations). Time per frame, with the solver's own
// split into counters.
void StepImplicitEpisode(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0)), threads = static_cast<int>(state.range(1));
  constexpr int kFrames = 15;
  SimulationSetup setup;
  ClothSetup c;
  GridSpec g;
  g.size_u = g.size_v = 1.0;
  g.nodes_u = g.nodes_v = n;
  g.plane = GridPlane::kXZ;
  g.origin = Vec3(-0.5, 1.5, -0.5);
  c.mesh = ClothMesh::grid(g);
  c.material = material_preset("cotton");
  c.material.damping = 0.0;
  c.material.areal_density = 0.2 / c.mesh->total_area();
  c.pins = {PinSpec{c.mesh->grid_index(0, 0), {}, {}, {}}, PinSpec{c.mesh->grid_index(n - 1, 0), {}, {}, {}}};
  setup.cloths = {c};
  setup.solver.method = "implicit_euler";
  setup.solver.params = {{"multigrid", 1}, {"cg_tolerance", 0.02}, {"cg_max_iterations", 10}};
  setup.frame_dt = 1.0 / 60.0;
  setup.threads = threads;
  setup.guard.enabled = false;
  std::map<std::string, double> sums;
  long episodes = 0;
  for (auto _ : state) {
    state.PauseTiming();
    Simulation sim(setup);
    ClothState& st = sim.cloths()[0]->state();
    for (int iv = 0; iv < n; ++iv)
      for (int iu = 0; iu < n; ++iu) {
        const int i = c.mesh->grid_index(iu, iv);
        if (st.inv_mass[i] != 0.0)
          st.x[i].y() += 1e-3 * std::sin(M_PI * iu / (n - 1.0)) * std::sin(0.5 * M_PI * iv / (n - 1.0));
      }
    st.x_prev = st.x;
    state.ResumeTiming();
    std::vector<FrameStats> frames;
    for (int f = 0; f < kFrames; ++f) frames.push_back(sim.step_frame());
    state.PauseTiming();
    const std::vector<std::string> names = sim.stage_names();
    for (const FrameStats& fs : frames) sums["pipeline_ms"] += pipeline_ms(names, fs);
    for (const StageProfile& row : sim.profile())
      if (row.name == "solve")
        for (const auto& kv : row.counters) sums[kv.first] += kv.second;
    ++episodes;
    state.ResumeTiming();
  }
  for (const char* k : {"pipeline_ms", "assembly_ms", "cg_ms", "safeguard_ms", "cg_iterations"})
    state.counters[k] = sums[k] / (episodes * double(kFrames));
}

}  // namespace

BENCHMARK(StepImplicitEpisode)->ArgsProduct({{64}, {1, 2}})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(GlobalSolveEigen)->Arg(65)->Arg(129)->Unit(benchmark::kMicrosecond);
BENCHMARK(GlobalSolveSplit)->ArgsProduct({{65, 129}, {1, 2}})->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(StepSymplecticEuler)
    ->ArgsProduct({{33, 65, 129}, {1, 2}, {0}, {0}})
    ->Unit(benchmark::kMicrosecond)
    ->UseManualTime();
BENCHMARK(StepVerlet)
    ->ArgsProduct({{33, 65, 129}, {1, 2}, {0}, {0}})
    ->Unit(benchmark::kMicrosecond)
    ->UseManualTime();
BENCHMARK(StepExplicitEuler)
    ->ArgsProduct({{33, 65, 129}, {1, 2}, {0}, {0}})
    ->Unit(benchmark::kMicrosecond)
    ->UseManualTime();
BENCHMARK(StepPbd)
    ->ArgsProduct({{65, 129}, {1, 2}, {1, 10}, {0, 16}})
    ->Unit(benchmark::kMicrosecond)
    ->UseManualTime();
BENCHMARK(StepXpbd)
    ->ArgsProduct({{65, 129}, {1, 2}, {1, 10}, {0, 16}})
    ->Unit(benchmark::kMicrosecond)
    ->UseManualTime();
BENCHMARK_MAIN();
