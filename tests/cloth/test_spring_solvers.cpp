// The spring-based solvers: pbd, xpbd, projective (Liu 2013 / projective dynamics, with
// Chebyshev acceleration) and desbrun. Their fixed points, monotonicity, pins and hard cases.
#include <gtest/gtest.h>

#include <Eigen/SparseCholesky>
#include <cmath>
#include <random>
#include <set>
#include <stdexcept>

#include "TestUtil.h"
#include "loom/cloth/DesbrunSolver.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/FastXpbdSolver.h"
#include "loom/cloth/ProjectiveSolver.h"
#include "loom/cloth/Simulation.h"
#include "loom/cloth/SplitCholesky.h"
#include "loom/cloth/SpringSolverSupport.h"

namespace loom::cloth {
namespace {

// A small cotton sheet, flat, two corners pinned, no damping (so the backward Euler equations of the
// spring energy are exactly what projective dynamics solves).
SimulationSetup sheet(int n, const std::string& method, std::map<std::string, double> params = {}) {
  SimulationSetup s = test::hanging_sheet(n);
  s.cloths[0].material.damping = 0.0;
  s.solver.method = method;
  s.solver.params = std::move(params);
  s.substeps = 4;
  return s;
}

// A start state off equilibrium: free vertices displaced by up to `amount` (m) and moving at up to
// 25 * amount (m/s).
void disturb(ClothState& s, unsigned seed, double amount = 0.02) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < s.size(); ++i) {
    if (s.inv_mass[i] == 0.0) continue;
    s.x[i] += amount * Vec3(u(rng), u(rng), u(rng));
    s.v[i] = 25.0 * amount * Vec3(u(rng), u(rng), u(rng));
  }
  s.x_prev = s.x;
}

// One step of `settings` from the disturbed start; returns the positions after the step.
Vec3s one_step(const SolverSettings& settings, double h, Vec3s* y_out = nullptr, double amount = 0.02) {
  SimulationSetup setup = sheet(9, "symplectic_euler");
  Simulation sim(setup);
  Cloth& cloth = *sim.cloths()[0];
  disturb(cloth.state(), 7, amount);
  if (y_out) {
    const ClothState& s = cloth.state();
    Vec3s f;
    external_forces(cloth, s.x, s.v, 0.0, 1, f);
    y_out->resize(s.size());
    for (int i = 0; i < s.size(); ++i) (*y_out)[i] = s.x[i] + h * (s.v[i] + h * s.inv_mass[i] * f[i]);
  }
  auto solver = make_solver(settings);
  solver->check(cloth);
  solver->step(cloth, 0.0, h, 1);
  return cloth.state().x;
}

// The positions of sheet(n)'s start state.
Vec3s sheet_start(int n) {
  Simulation sim(sheet(n, "symplectic_euler"));
  return sim.cloths()[0]->state().x;
}

double rms_difference(const Vec3s& a, const Vec3s& b) {
  double sum = 0.0;
  for (size_t i = 0; i < a.size(); ++i) sum += (a[i] - b[i]).squaredNorm();
  return std::sqrt(sum / a.size());
}

// |M (x - y) - h² f_springs(x)| over free vertices: the backward Euler residual, computed here from the
// SpringTerm itself (not from the solver).
double backward_euler_residual(const Vec3s& x, const Vec3s& y, double h) {
  Simulation sim(sheet(9, "symplectic_euler"));
  const Cloth& cloth = *sim.cloths()[0];
  const ClothState& s = cloth.state();
  Vec3s f(x.size(), Vec3::Zero());
  const Vec3s v(x.size(), Vec3::Zero());
  const EvalContext ctx{x, v, 0.0, 1};
  cloth.find_term("springs")->add_forces(ctx, f);
  double sum = 0.0;
  for (int i = 0; i < s.size(); ++i)
    if (s.inv_mass[i] > 0.0) sum += (s.mass[i] * (x[i] - y[i]) - h * h * f[i]).squaredNorm();
  return std::sqrt(sum);
}

SolverSettings settings(const std::string& method, std::map<std::string, double> params) {
  SolverSettings s;
  s.method = method;
  s.params = std::move(params);
  return s;
}

const double kH = 1.0 / 120.0;

TEST(ProjectiveDynamics, FixedPointIsTheBackwardEulerStep) {
  Vec3s y;
  // Converged with Chebyshev (plain iterations converge at a rate of about 0.998 here).
  const Vec3s x =
      one_step(settings("projective", {{"iterations", 3000}, {"chebyshev", 1}, {"rho", 0.99}}), kH, &y);
  const double r0 = backward_euler_residual(y, y, kH);
  EXPECT_LT(backward_euler_residual(x, y, kH), 1e-11 * r0);
}

TEST(ProjectiveDynamics, ObjectiveNeverIncreasesAndResidualShrinks) {
  SimulationSetup setup = sheet(9, "projective");
  Simulation sim(setup);
  Cloth& cloth = *sim.cloths()[0];
  disturb(cloth.state(), 7);
  ProjectiveSettings ps;
  ps.iterations = 200;
  ProjectiveSolver solver(ps);
  solver.record_iterations(true);
  solver.step(cloth, 0.0, kH, 1);
  const auto& trace = solver.last_iterations();
  ASSERT_EQ(trace.size(), 201u);
  for (size_t k = 1; k < trace.size(); ++k)
    EXPECT_LE(trace[k].objective, trace[k - 1].objective * (1.0 + 1e-13)) << "iteration " << k;
  EXPECT_LT(trace[10].residual, trace[1].residual);
  EXPECT_LT(trace[100].residual, 0.5 * trace[10].residual);
  EXPECT_LT(trace[200].residual, 0.5 * trace[100].residual);
}

TEST(ProjectiveDynamics, ResidualOfBackwardEulerShrinksWithIterations) {
  Vec3s y;
  double previous = 1e300;
  for (int it : {1, 10, 100, 1000}) {
    const Vec3s x = one_step(settings("projective", {{"iterations", it}}), kH, &y);
    const double r = backward_euler_residual(x, y, kH);
    EXPECT_LT(r, previous) << it << " iterations";
    previous = r;
  }
}

TEST(ProjectiveDynamics, ChebyshevReachesTheSameResidualInFewerIterations) {
  auto iterations_to = [](bool chebyshev, double target) {
    Simulation sim(sheet(9, "projective"));
    Cloth& cloth = *sim.cloths()[0];
    disturb(cloth.state(), 7);
    ProjectiveSettings ps;
    ps.iterations = 5000;
    ps.chebyshev = chebyshev;
    ps.rho = 0.99;
    ProjectiveSolver solver(ps);
    solver.record_iterations(true);
    solver.step(cloth, 0.0, kH, 1);
    const auto& trace = solver.last_iterations();
    for (size_t k = 0; k < trace.size(); ++k)
      if (trace[k].residual < target * trace[0].residual) return static_cast<int>(k);
    return 1 << 30;
  };
  const int plain = iterations_to(false, 1e-6);
  const int fast = iterations_to(true, 1e-6);
  EXPECT_LT(plain, 5000);
  EXPECT_LT(fast, plain / 2) << "plain " << plain << ", chebyshev " << fast;
}

TEST(ProjectiveDynamics, TriangleStrainProjectionLimitsStretch) {
  double strain[2];
  for (int limit = 0; limit < 2; ++limit) {
    SimulationSetup setup = sheet(9, "projective");
    if (limit) setup.solver.params = {{"strain_limit", 0.1}};
    auto& m = setup.cloths[0].material;
    m.stretch_weft = m.stretch_warp = 30.0;  // soft: sags far beyond 10% without the limit
    m.shear = 15.0;
    Simulation sim(setup);
    strain[limit] = 0.0;
    for (int f = 0; f < 40; ++f) strain[limit] = std::max(strain[limit], sim.step_frame().max_strain);
  }
  EXPECT_GT(strain[0], 0.3);
  EXPECT_LT(strain[1], 0.11);
}

TEST(ProjectiveDynamics, ObjectiveNeverIncreasesWithTheStrainProjection) {
  Simulation sim(sheet(9, "projective"));
  Cloth& cloth = *sim.cloths()[0];
  disturb(cloth.state(), 7, 0.05);
  ProjectiveSettings ps;
  ps.iterations = 50;
  ps.strain_limit = 0.05;
  ProjectiveSolver solver(ps);
  solver.record_iterations(true);
  solver.step(cloth, 0.0, kH, 1);
  const auto& trace = solver.last_iterations();
  for (size_t k = 1; k < trace.size(); ++k)
    EXPECT_LE(trace[k].objective, trace[k - 1].objective * (1.0 + 1e-13)) << "iteration " << k;
  EXPECT_LT(trace.back().residual, 0.5 * trace[1].residual);
}

TEST(Xpbd, ApproachesTheBackwardEulerStepAsIterationsGrow) {
  // XPBD's Gauss-Seidel fixed point differs from backward Euler by the rotation of the constraint
  // gradients within the step (Macklin 2016 drops that term), so a gentle start (2 mm, 5 cm/s) is used:
  // the error then falls by more than 100x before it levels off.
  const double amount = 0.002;
  const Vec3s reference = one_step(
      settings("projective", {{"iterations", 3000}, {"chebyshev", 1}, {"rho", 0.99}}), kH, nullptr, amount);
  std::vector<double> errors;
  for (int it : {1, 4, 16, 64, 256})
    errors.push_back(
        rms_difference(one_step(settings("xpbd", {{"iterations", it}}), kH, nullptr, amount), reference));
  for (size_t k = 1; k < errors.size(); ++k) EXPECT_LT(errors[k], errors[k - 1]) << "step " << k;
  EXPECT_LT(errors.back(), 0.01 * errors.front());
}

TEST(Xpbd, ZeroComplianceStaysFiniteAndInextensible) {
  SimulationSetup setup = sheet(9, "xpbd", {{"compliance_scale", 0.0}, {"iterations", 20}});
  Simulation sim(setup);
  FrameStats st;
  for (int f = 0; f < 30; ++f) st = sim.step_frame();
  EXPECT_TRUE(st.finite);
  EXPECT_LT(st.max_strain, 0.01);
}

TEST(Xpbd, ZeroComplianceWithPinsPulledToThreeTimesTheSizeStaysFinite) {
  SimulationSetup setup = sheet(9, "xpbd", {{"compliance_scale", 0.0}});
  auto& pins = setup.cloths[0].pins;
  pins[0].times = pins[1].times = {0.0, 0.5};
  pins[0].offsets = {Vec3::Zero(), Vec3(-1.0, 0, 0)};
  pins[1].offsets = {Vec3::Zero(), Vec3(1.0, 0, 0)};
  Simulation sim(setup);
  const FrameStats start = sim.measure();
  for (int f = 0; f < 60; ++f) {
    const FrameStats st = sim.step_frame();
    ASSERT_TRUE(st.finite) << "frame " << f;
    EXPECT_LT(st.kinetic + st.potential, 10.0 * std::abs(start.potential) + 1.0);
  }
}

// fast_xpbd is XPBD with float corrections and SSE lanes: one step agrees with xpbd's to float rounding
// (corrections of ~1 cm, float's relative 6e-8: well under a micrometre), damped and undamped.
TEST(FastXpbd, OneStepMatchesXpbdToFloatRounding) {
  for (double damping : {0.0, 1e-3}) {
    Vec3s x[2];
    const char* methods[2] = {"xpbd", "fast_xpbd"};
    for (int m = 0; m < 2; ++m) {
      SimulationSetup setup = sheet(9, methods[m], {{"iterations", 1}});
      setup.cloths[0].material.damping = damping;
      Simulation sim(setup);
      disturb(sim.cloths()[0]->state(), 3);
      sim.step_frame();
      x[m] = sim.cloths()[0]->state().x;
    }
    EXPECT_LT(rms_difference(x[0], x[1]), 1e-6) << "damping " << damping;
    EXPECT_GT(rms_difference(x[0], sheet_start(9)), 1e-3) << "the step moved the sheet";
  }
}

// Many small substeps with one iteration (Macklin et al. 2019): a hanging sheet's stretch falls as substeps
// grow at a fixed cost per frame, and the energy does not grow on an undamped swing.
TEST(FastXpbd, MoreSubstepsGiveLessStretch) {
  double strain[3];
  int k = 0;
  for (int substeps : {4, 16, 64}) {
    SimulationSetup setup = sheet(13, "fast_xpbd", {{"iterations", 1}});
    setup.substeps = substeps;
    Simulation sim(setup);
    FrameStats st;
    for (int f = 0; f < 90; ++f) st = sim.step_frame();
    ASSERT_TRUE(st.finite);
    strain[k++] = st.max_strain;
  }
  EXPECT_LT(strain[1], strain[0]);
  EXPECT_LT(strain[2], strain[1]);
}

TEST(FastXpbd, EnergyDoesNotGrowOnAnUndampedSwing) {
  SimulationSetup setup = sheet(11, "fast_xpbd");
  setup.substeps = 16;
  Simulation sim(setup);
  const FrameStats start = sim.measure();
  const double e0 = start.kinetic + start.potential + start.elastic;
  // One Gauss-Seidel sweep does not conserve energy exactly: the total wanders by well under 1 % of the
  // start's while the sheet swings, and the swing loses energy over time (no growth).
  double late = 0.0;
  for (int f = 0; f < 180; ++f) {
    const FrameStats st = sim.step_frame();
    ASSERT_TRUE(st.finite) << "frame " << f;
    const double e = st.kinetic + st.potential + st.elastic;
    EXPECT_LT(e, e0 + 0.01 * std::abs(e0)) << "frame " << f;
    if (f >= 120) late = std::max(late, e);
  }
  EXPECT_LT(late, e0);
}

TEST(SpringSolvers, PinsFollowTheirTargetsExactly) {
  for (const char* method : {"pbd", "xpbd", "fast_xpbd", "projective", "desbrun"}) {
    SimulationSetup setup = sheet(7, method);
    setup.cloths[0].pins[1].times = {0.0, 0.2};
    setup.cloths[0].pins[1].offsets = {Vec3::Zero(), Vec3(0.1, 0.2, 0.0)};
    Simulation sim(setup);
    for (int f = 0; f < 12; ++f) {
      const FrameStats st = sim.step_frame();
      ASSERT_TRUE(st.finite) << method;
      const ClothState& s = sim.cloths()[0]->state();
      for (const Pin& p : sim.cloths()[0]->pins())
        EXPECT_LT((s.x[p.vertex] - p.target(sim.time())).norm(), 1e-12) << method << " frame " << f;
    }
  }
}

TEST(SpringSolvers, HangingSheetSettlesWithBoundedStrain) {
  // Every solver, realistic settings: the sheet falls and hangs, stays finite, strain stays moderate.
  for (const char* method : {"pbd", "xpbd", "fast_xpbd", "projective", "desbrun"}) {
    SimulationSetup setup = sheet(9, method);
    setup.cloths[0].material.damping = 1e-4;
    // fast_xpbd spends the sweeps of the others' 10 iterations on substeps (one iteration each).
    if (std::string(method) == "fast_xpbd") setup.substeps *= 10;
    Simulation sim(setup);
    double lowest = 1e9;
    for (int f = 0; f < 60; ++f) {
      const FrameStats st = sim.step_frame();
      ASSERT_TRUE(st.finite) << method;
      EXPECT_LT(st.max_strain, 0.2) << method;
      lowest = std::min(lowest, sim.cloths()[0]->state().x.back().y());
    }
    // It swung down: the free corner far from the pins went well below the start height (1 m).
    EXPECT_LT(lowest, 0.3) << method;
  }
}

TEST(SpringSolvers, ProjectiveFactorisesOnlyWhenTheStepChanges) {
  Simulation sim(sheet(7, "symplectic_euler"));
  Cloth& cloth = *sim.cloths()[0];
  ProjectiveSolver solver(ProjectiveSettings{});
  for (int k = 0; k < 5; ++k) solver.step(cloth, 0.0, 0.01, 1);
  EXPECT_EQ(solver.factorizations(), 1);
  solver.step(cloth, 0.0, 0.005, 1);
  EXPECT_EQ(solver.factorizations(), 2);
}

// The system matrix M + a L_k + b L_c of an n x n hanging sheet (two corners pinned), over its free vertices.
Eigen::SparseMatrix<double> sheet_matrix(int n) {
  Simulation sim(sheet(n, "symplectic_euler"));
  const ClothState& s = sim.cloths()[0]->state();
  int nf = 0;
  const std::vector<int> index = free_index(s, &nf);
  return spring_system_matrix(s, index, nf, collect_springs(*sim.cloths()[0]), 1e-4, 1e-2);
}

Eigen::MatrixX3d random_rows(int rows, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixX3d b(rows, 3);
  for (int i = 0; i < rows; ++i)
    for (int c = 0; c < 3; ++c) b(i, c) = u(rng);
  return b;
}

TEST(SplitCholesky, SolvesLikeEigensCholeskyOnOneAndTwoThreadsWithTheSameBits) {
  // 48x48 sheet: 2302 free vertices, above kMinSplit, so the graph is split by a separator.
  const Eigen::SparseMatrix<double> a = sheet_matrix(48);
  SplitCholesky factor;
  ASSERT_TRUE(factor.compute(a)) << factor.error();
  const auto parts = factor.part_sizes();
  EXPECT_EQ(parts[0] + parts[1] + parts[2], a.rows());
  // Both halves hold a real share, and the separator is a thin band (one BFS level of a 48x48 sheet with
  // bending springs of reach 2 is at most a few rows of vertices).
  EXPECT_GT(parts[0], a.rows() / 4);
  EXPECT_GT(parts[1], a.rows() / 4);
  EXPECT_GT(parts[2], 0);
  EXPECT_LT(parts[2], a.rows() / 10);
  EXPECT_EQ(factor.entries_joining_the_parts(), 0);
  EXPECT_GT(factor.off_diagonal_entries(), a.nonZeros() / 2);

  const Eigen::MatrixX3d b = random_rows(static_cast<int>(a.rows()), 5);
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> eigen(a);
  ASSERT_EQ(eigen.info(), Eigen::Success);
  const Eigen::MatrixX3d want = eigen.solve(b);
  Eigen::MatrixX3d got[2];
  for (int t = 0; t < 2; ++t) factor.solve(b, got[t], t + 1);
  EXPECT_TRUE((got[0].array() == got[1].array()).all());
  EXPECT_LT((got[0] - want).norm(), 1e-12 * want.norm());
  EXPECT_LT((a * got[0] - b).norm(), 1e-12 * b.norm());
}

TEST(SplitCholesky, SmallAndDisconnectedMatricesAreSolvedWhole) {
  // Below kMinSplit: one part, no separator.
  const Eigen::SparseMatrix<double> small = sheet_matrix(12);
  SplitCholesky factor;
  ASSERT_TRUE(factor.compute(small)) << factor.error();
  EXPECT_EQ(factor.part_sizes()[0], small.rows());
  Eigen::MatrixX3d b = random_rows(static_cast<int>(small.rows()), 6), x;
  factor.solve(b, x, 2);
  EXPECT_LT((small * x - b).norm(), 1e-12 * b.norm());
  // Unsplit, it is Eigen's factorisation (same AMD order) and Eigen's substitutions: the same bits, so the
  // solvers' results on small cloths did not move when SplitCholesky replaced SimplicialLLT.
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> eigen(small);
  ASSERT_EQ(eigen.info(), Eigen::Success);
  const Eigen::MatrixX3d want = eigen.solve(b);
  EXPECT_TRUE((x.array() == want.array()).all()) << (x - want).cwiseAbs().maxCoeff();

  // Two copies of a 48x48 sheet side by side: the root's component is half the graph, the other copy joins
  // the smaller part whole; the solve stays exact.
  const Eigen::SparseMatrix<double> one = sheet_matrix(48);
  const int m = static_cast<int>(one.rows());
  std::vector<Eigen::Triplet<double>> trip;
  for (int j = 0; j < m; ++j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(one, j); it; ++it) {
      trip.emplace_back(it.row(), j, it.value());
      trip.emplace_back(it.row() + m, j + m, it.value());
    }
  Eigen::SparseMatrix<double> two(2 * m, 2 * m);
  two.setFromTriplets(trip.begin(), trip.end());
  ASSERT_TRUE(factor.compute(two)) << factor.error();
  EXPECT_EQ(factor.entries_joining_the_parts(), 0);
  b = random_rows(2 * m, 7);
  Eigen::MatrixX3d x2;
  factor.solve(b, x, 1);
  factor.solve(b, x2, 2);
  EXPECT_TRUE((x.array() == x2.array()).all());
  EXPECT_LT((two * x - b).norm(), 1e-12 * b.norm());
}

TEST(SplitCholesky, AnIndefiniteMatrixIsRefusedWithAReason) {
  // Whole (12x12 sheet) and split (48x48): a negative diagonal entry at the start, middle and end of the
  // matrix, wherever the ordering puts it (either half or the separator).
  for (int n : {12, 48}) {
    const Eigen::SparseMatrix<double> a = sheet_matrix(n);
    for (int v : {3, static_cast<int>(a.rows()) / 2, static_cast<int>(a.rows()) - 4}) {
      Eigen::SparseMatrix<double> bad = a;
      bad.coeffRef(v, v) = -1.0;
      SplitCholesky factor;
      EXPECT_FALSE(factor.compute(bad)) << n << " " << v;
      EXPECT_FALSE(factor.ok());
      EXPECT_NE(factor.error().find("positive definite"), std::string::npos) << factor.error();
      // A refused factor is empty: a solve with it throws instead of reading another size's arrays.
      Eigen::MatrixX3d x;
      EXPECT_THROW(factor.solve(random_rows(static_cast<int>(a.rows()), 8), x, 1), std::logic_error);
    }
  }
}

TEST(SpringSolvers, ResultsDoNotDependOnTheThreadCount) {
  for (const char* method : {"pbd", "xpbd", "fast_xpbd", "projective", "desbrun"}) {
    Vec3s x[2];
    for (int t = 0; t < 2; ++t) {
      // 48x48: the parallel loops run in parallel, and the global matrix is big enough to be split
      // (SplitCholesky::kMinSplit), so projective's and desbrun's solves run one half per thread.
      SimulationSetup setup = sheet(48, method);
      setup.threads = t + 1;
      setup.substeps = 2;
      Simulation sim(setup);
      sim.step_frame();
      x[t] = sim.cloths()[0]->state().x;
    }
    for (size_t i = 0; i < x[0].size(); ++i) ASSERT_EQ(x[0][i], x[1][i]) << method;
  }
}

// fast_xpbd's colours: every spring of the cloth exactly once, and no vertex twice within one colour (so a
// colour's springs can be projected in any order, in SIMD lanes or on several threads).
TEST(FastXpbd, EverySpringOnceAndNoSharedVertexWithinAColour) {
  Simulation sim(sheet(48, "symplectic_euler"));
  Cloth& cloth = *sim.cloths()[0];
  FastXpbdSolver solver(1, 1.0);
  EXPECT_TRUE(solver.spring_colors().empty());
  solver.step(cloth, 0.0, kH, 1);
  const auto colors = solver.spring_colors();
  ASSERT_GE(colors.size(), 2u);
  std::set<std::pair<int, int>> seen;
  size_t total = 0;
  for (size_t c = 0; c < colors.size(); ++c) {
    std::set<int> vertices;
    for (const auto& ij : colors[c]) {
      EXPECT_TRUE(vertices.insert(ij.first).second) << "colour " << c << " vertex " << ij.first;
      EXPECT_TRUE(vertices.insert(ij.second).second) << "colour " << c << " vertex " << ij.second;
      seen.insert({std::min(ij.first, ij.second), std::max(ij.first, ij.second)});
    }
    total += colors[c].size();
  }
  std::set<std::pair<int, int>> expected;
  for (const Spring& sp : collect_springs(cloth))
    if (sp.k > 0.0) expected.insert({std::min(sp.i, sp.j), std::max(sp.i, sp.j)});
  EXPECT_EQ(total, expected.size());
  EXPECT_EQ(seen, expected);
}

// The coloured step on one or two threads, in AVX, SSE or scalar lanes (those this processor runs): the
// same bits after ten steps, damped and undamped.
TEST(FastXpbd, ThreadsAndVectorFormsGiveTheSameBits) {
  for (double damping : {0.0, 1e-3}) {
    Vec3s first;
    for (int lanes : {8, 4, 1})
      for (int threads : {1, 2}) {
        SimulationSetup setup = sheet(48, "symplectic_euler");
        setup.cloths[0].material.damping = damping;
        Simulation sim(setup);
        Cloth& cloth = *sim.cloths()[0];
        disturb(cloth.state(), 5);
        FastXpbdSolver solver(1, 1.0);
        solver.set_lanes(lanes);
        for (int k = 0; k < 10; ++k) solver.step(cloth, k * kH, kH, threads);
        const Vec3s& x = cloth.state().x;
        ASSERT_TRUE(cloth.state().is_finite());
        if (first.empty()) {
          first = x;
          EXPECT_GT(rms_difference(x, sheet_start(48)), 1e-3) << "the steps moved the sheet";
          continue;
        }
        for (size_t i = 0; i < x.size(); ++i)
          ASSERT_EQ(x[i], first[i]) << "lanes " << lanes << " threads " << threads << " damping " << damping
                                    << " vertex " << i;
      }
  }
}

// Angular momentum of a cloth about the origin (kg·m²/s).
Vec3 angular_momentum(const ClothState& s) {
  Vec3 l = Vec3::Zero();
  for (int i = 0; i < s.size(); ++i) l += s.mass[i] * s.x[i].cross(s.v[i]);
  return l;
}

TEST(Desbrun, AngularMomentumCorrectionKeepsASpinningFreeSheetsMomentum) {
  double drift[2];
  for (int correct = 0; correct < 2; ++correct) {
    SimulationSetup setup = sheet(7, "symplectic_euler");
    setup.cloths[0].pins.clear();
    setup.gravity = Vec3::Zero();
    Simulation sim(setup);
    ClothState& s = sim.cloths()[0]->state();
    disturb(s, 5, 0.01);
    // Spin about the vertical axis through the middle (the sheet lies in y = 1): centrifugal stretch.
    for (int i = 0; i < s.size(); ++i) s.v[i] += Vec3(0, 6.0, 0).cross(s.x[i] - Vec3(0, 1, 0));
    const Vec3 l0 = angular_momentum(s);
    DesbrunSolver solver(correct == 1);
    for (int k = 0; k < 30; ++k) solver.step(*sim.cloths()[0], 0.0, 1.0 / 60.0, 1);
    drift[correct] = (angular_momentum(s) - l0).norm() / l0.norm();
  }
  EXPECT_LT(drift[1], 1e-10);
  EXPECT_GT(drift[0], 1e-3);
}

// An elastic term none of the spring solvers can project or filter.
class MysteryTerm final : public Term {
 public:
  const char* name() const override { return "mystery"; }
  double energy(const EvalContext&) const override { return 0.0; }
  void add_forces(const EvalContext&, Vec3s&) const override {}
  void add_jacobians(const EvalContext&, const JacobianOptions&, BlockMatrix*, BlockMatrix*) const override {}
};

// takes_springs_only (what scenes check a cloth's model against) names exactly the methods whose check()
// refuses a term that is not a spring.
TEST(SpringSolvers, TakesSpringsOnlyNamesTheMethodsThatRefuseOtherTerms) {
  for (const std::string& method : solver_names()) {
    Simulation sim(sheet(5, "symplectic_euler"));
    Cloth& cloth = *sim.cloths()[0];
    cloth.add_term(std::make_unique<MysteryTerm>());
    bool refused = false;
    try {
      make_solver(settings(method, {}))->check(cloth);
    } catch (const Error&) {
      refused = true;
    }
    EXPECT_EQ(refused, takes_springs_only(method)) << method;
  }
  EXPECT_TRUE(takes_springs_only("fast_xpbd"));
  EXPECT_FALSE(takes_springs_only("implicit_euler"));
}

TEST(SpringSolvers, RejectTermsTheyCannotUseNamingThem) {
  for (const char* method : {"pbd", "xpbd", "projective", "desbrun"}) {
    Simulation sim(sheet(5, "symplectic_euler"));
    Cloth& cloth = *sim.cloths()[0];
    auto solver = make_solver(settings(method, {}));
    EXPECT_NO_THROW(solver->check(cloth)) << method;
    cloth.add_term(std::make_unique<MysteryTerm>());
    try {
      solver->check(cloth);
      ADD_FAILURE() << method << " accepted an unknown term";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("'mystery'"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(method), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace loom::cloth
