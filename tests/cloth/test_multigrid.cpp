// The aggregation multigrid preconditioner of the filtered PCG (AggregationMultigrid.h): constraints honoured
// exactly, the same solution as block-Jacobi, fewer iterations, thread-count independence, and the
// implicit_euler run it serves.
#include <gtest/gtest.h>

#include <random>

#include "SymplecticSetup.h"
#include "loom/cloth/AggregationMultigrid.h"
#include "loom/cloth/FilteredPCG.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

// The matrix of an implicit cloth step on an n x n grid (1 m square): A = m I + h² K with K the stiffness of
// axial springs (k n nᵀ per edge: structural, shear and bend neighbours, as SpringSet builds them), stiffness
// dominated like the accuracy bench's cotton at 60 Hz; a random small out-of-plane jitter so that the blocks
// are not axis-aligned.
BlockMatrix cloth_matrix(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double dx = 1.0 / (n - 1), mass = 0.2 / (n * n), h = 1.0 / 60.0;
  Vec3s x(n * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) x[j * n + i] = Vec3(i * dx, 0.1 * dx * u(rng), j * dx);
  struct E {
    int a, b;
    double k;  // N/m
  };
  std::vector<E> edges;
  std::vector<std::pair<int, int>> pairs;
  auto add = [&](int i0, int j0, int i1, int j1, double k) {
    if (i1 < 0 || j1 < 0 || i1 >= n || j1 >= n) return;
    edges.push_back({j0 * n + i0, j1 * n + i1, k});
    pairs.emplace_back(j0 * n + i0, j1 * n + i1);
  };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      add(i, j, i + 1, j, 2000.0);
      add(i, j, i, j + 1, 2000.0);
      add(i, j, i + 1, j + 1, 100.0);
      add(i, j, i - 1, j + 1, 100.0);
      add(i, j, i + 2, j, 1.0);
      add(i, j, i, j + 2, 1.0);
    }
  BlockMatrix A(n * n, pairs);
  for (int i = 0; i < n * n; ++i) A.add(i, i, mass * Mat3::Identity());
  for (const E& e : edges) {
    const Vec3 d = (x[e.b] - x[e.a]).normalized();
    const Mat3 c = h * h * e.k * d * d.transpose();
    A.add(e.a, e.a, c);
    A.add(e.b, e.b, c);
    A.add(e.a, e.b, -c);
    A.add(e.b, e.a, -c);
  }
  return A;
}

struct Problem {
  BlockMatrix A;
  Vec3s b, z;  // right-hand side; prescribed values on fixed vertices
  std::vector<char> fixed;
};

// Two pinned corners of one edge (the hanging cloth's pins) with prescribed velocity changes, a gravity-like
// load plus noise on the free vertices.
Problem hanging_problem(int n, unsigned seed) {
  Problem p{cloth_matrix(n, seed), {}, {}, {}};
  std::mt19937 rng(seed + 1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int nv = n * n;
  p.b.resize(nv);
  for (Vec3& v : p.b) v = Vec3(1e-4 * u(rng), -1e-3 + 1e-4 * u(rng), 1e-4 * u(rng));
  p.fixed.assign(nv, 0);
  p.z.assign(nv, Vec3::Zero());
  p.fixed[0] = p.fixed[n - 1] = 1;
  p.z[0] = Vec3(0.01, -0.02, 1.0 / 3.0);
  p.z[n - 1] = Vec3(-0.005, 0.0, 0.125);
  return p;
}

PcgResult solve(const Problem& p, Preconditioner pre, double tol, Vec3s& dv, int threads = 1,
                MultigridCycle cycle = MultigridCycle::kAdditiveFinest) {
  dv = p.z;
  FilteredPCG pcg;
  pcg.set_preconditioner(pre, cycle);
  return pcg.solve(p.A, p.b, p.fixed, dv, tol, 5000, threads);
}

double free_residual(const Problem& p, const Vec3s& dv) {
  Vec3s Ad;
  p.A.multiply(dv, Ad);
  double worst = 0.0;
  for (size_t i = 0; i < dv.size(); ++i)
    if (!p.fixed[i]) worst = std::max(worst, (Ad[i] - p.b[i]).norm());
  return worst;
}

TEST(Multigrid, BuildsACoarseningHierarchyOfTheFreeVertices) {
  const Problem p = hanging_problem(40, 5);
  AggregationMultigrid mg;
  mg.setup(p.A, p.fixed, 1);
  ASSERT_GE(mg.levels(), 3);
  EXPECT_EQ(mg.vertices(0), 1600);
  for (int l = 1; l < mg.levels(); ++l) EXPECT_LT(mg.vertices(l), mg.vertices(l - 1) / 2) << l;
  EXPECT_LE(mg.vertices(mg.levels() - 1), 48);
  // The values change, the pattern and fixed set do not: the hierarchy is reused.
  mg.setup(p.A, p.fixed, 1);
  EXPECT_EQ(mg.pattern_builds(), 1);
  std::vector<char> other = p.fixed;
  other[5] = 1;
  mg.setup(p.A, other, 1);
  EXPECT_EQ(mg.pattern_builds(), 2);
}

TEST(Multigrid, PreconditionerIsSymmetricAndZeroOnFixedVertices) {
  // CG needs a symmetric preconditioner: uᵀ B w == wᵀ B u for random u, w (filtered), and B r = 0 on fixed.
  const Problem p = hanging_problem(24, 9);
  for (MultigridCycle cycle : {MultigridCycle::kAdditiveFinest, MultigridCycle::kVCycle}) {
    MultigridSettings settings;
    settings.cycle = cycle;
    AggregationMultigrid mg(settings);
    mg.setup(p.A, p.fixed, 1);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Vec3s a(p.A.size()), c(p.A.size()), Ba, Bc;
    for (int i = 0; i < p.A.size(); ++i) {
      a[i] = p.fixed[i] ? Vec3::Zero() : Vec3(u(rng), u(rng), u(rng));
      c[i] = p.fixed[i] ? Vec3::Zero() : Vec3(u(rng), u(rng), u(rng));
    }
    mg.apply(a, Ba, 1);
    mg.apply(c, Bc, 1);
    double cBa = 0.0, aBc = 0.0, aBa = 0.0;
    for (int i = 0; i < p.A.size(); ++i) {
      cBa += c[i].dot(Ba[i]);
      aBc += a[i].dot(Bc[i]);
      aBa += a[i].dot(Ba[i]);
      if (p.fixed[i]) {
        EXPECT_EQ(Ba[i], Vec3::Zero()) << i;
      }
    }
    EXPECT_NEAR(cBa, aBc, 1e-10 * std::abs(aBa));
    EXPECT_GT(aBa, 0.0);
  }
}

TEST(Multigrid, FilteredPcgHonoursConstraintsAndMatchesBlockJacobiInFewerIterations) {
  const Problem p = hanging_problem(48, 1);
  for (MultigridCycle cycle : {MultigridCycle::kAdditiveFinest, MultigridCycle::kVCycle}) {
    Vec3s jacobi, mg;
    const PcgResult rj = solve(p, Preconditioner::kBlockJacobi, 1e-10, jacobi);
    const PcgResult rm = solve(p, Preconditioner::kMultigrid, 1e-10, mg, 1, cycle);
    ASSERT_TRUE(rj.converged);
    ASSERT_TRUE(rm.converged);
    // Pinned vertices keep their prescribed values bit-exactly.
    for (int i = 0; i < p.A.size(); ++i)
      if (p.fixed[i]) {
        EXPECT_EQ(mg[i], p.z[i]) << i;
        EXPECT_EQ(jacobi[i], p.z[i]) << i;
      }
    // The same solution of the free block.
    double scale = 0.0, diff = 0.0;
    for (int i = 0; i < p.A.size(); ++i) {
      scale = std::max(scale, jacobi[i].norm());
      diff = std::max(diff, (mg[i] - jacobi[i]).norm());
    }
    EXPECT_LT(diff, 1e-7 * scale);
    double bmax = 0.0;
    for (const Vec3& v : p.b) bmax = std::max(bmax, v.norm());
    EXPECT_LT(free_residual(p, mg), 1e-7 * bmax);
    // Iterations: block-Jacobi needs ~N (the pins' load crosses the grid one vertex per iteration); the
    // V-cycle carries it in one application. At 1e-10 and at the bench's 1e-2:
    EXPECT_LT(3 * rm.iterations, rj.iterations) << rm.iterations << " vs " << rj.iterations;
    const int j2 = solve(p, Preconditioner::kBlockJacobi, 1e-2, jacobi).iterations;
    const int m2 = solve(p, Preconditioner::kMultigrid, 1e-2, mg, 1, cycle).iterations;
    EXPECT_LT(3 * m2, j2) << m2 << " vs " << j2;
    std::printf("%s: iterations to 1e-10: block-Jacobi %d, multigrid %d; to 1e-2: %d, %d\n",
                cycle == MultigridCycle::kVCycle ? "V-cycle" : "additive finest", rj.iterations,
                rm.iterations, j2, m2);
  }
}

TEST(Multigrid, LargeSystemIsBitIdenticalForOneAndTwoThreads) {
  const Problem p = hanging_problem(50, 2);  // 2500 vertices: above the parallel threshold
  Vec3s out[2];
  int it[2];
  for (MultigridCycle cycle : {MultigridCycle::kAdditiveFinest, MultigridCycle::kVCycle}) {
    for (int th = 1; th <= 2; ++th)
      it[th - 1] = solve(p, Preconditioner::kMultigrid, 1e-8, out[th - 1], th, cycle).iterations;
    EXPECT_EQ(it[0], it[1]);
    for (int i = 0; i < p.A.size(); ++i) ASSERT_EQ(out[0][i], out[1][i]) << i;
  }
}

TEST(Multigrid, ImplicitEulerWithMultigridMatchesBlockJacobiAtTightTolerance) {
  // The accuracy bench's hanging cloth at N=24 for 3 frames (60 Hz, 1 substep): the two preconditioners at
  // cg_tolerance 1e-9 give the same motion; the pinned corners stay exactly where they are.
  Vec3s out[3];
  double its[3];
  for (int mg = 0; mg <= 2; ++mg) {
    SimulationSetup s = loom::test::symplectic_setup();
    ClothSetup c;
    GridSpec g;
    g.nodes_u = g.nodes_v = 24;
    g.plane = GridPlane::kXZ;
    g.origin = Vec3(-0.5, 1.5, -0.5);
    c.mesh = ClothMesh::grid(g);
    c.material = material_preset("cotton");
    c.material.damping = 0.0;
    c.material.areal_density = 0.2 / c.mesh->total_area();
    c.pins = {PinSpec{0, {}, {}, {}}, PinSpec{23, {}, {}, {}}};
    s.cloths.push_back(c);
    s.solver.method = "implicit_euler";
    s.solver.params = {{"cg_tolerance", 1e-9}, {"multigrid", double(mg)}};
    s.frame_dt = 1.0 / 60.0;
    Simulation sim(s);
    const Vec3 pin0 = sim.cloths()[0]->state().x[0];
    for (int f = 0; f < 3; ++f) sim.step_frame();
    EXPECT_EQ(sim.cloths()[0]->state().x[0], pin0);
    out[mg] = sim.cloths()[0]->state().x;
    its[mg] = 0.0;
    for (const auto& pr : sim.profile())
      for (const auto& kv : pr.counters)
        if (kv.first == "cg_iterations") its[mg] = kv.second;
  }
  for (int mg = 1; mg <= 2; ++mg) {
    double diff = 0.0;
    for (size_t i = 0; i < out[0].size(); ++i) diff = std::max(diff, (out[0][i] - out[mg][i]).norm());
    EXPECT_LT(diff, 1e-6) << "multigrid " << mg;  // m
    EXPECT_LT(its[mg], its[0]) << "multigrid " << mg;
  }
}

}  // namespace
}  // namespace loom::cloth
