// IMEX integration: stiff in-plane terms linearised backward Euler, bending and the rest explicit.
// Stable on the hanging cloth at 60 Hz with one step per frame, first-order convergence to a fine reference,
// identical to implicit_euler when there is nothing explicit to split off, parameter errors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "TestUtil.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/ImplicitSolver.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

double total_energy(const FrameStats& s) { return s.kinetic + s.potential + s.elastic; }

// The benchmark scene of scenes/hanging_cloth.json: 1 m cotton square, 0.2 kg, 33 x 33 nodes, two corners
// of one edge pinned, damping 1e-5 s, 60 Hz.
SimulationSetup hanging_cloth(const std::string& model, int n = 33) {
  SimulationSetup s = test::hanging_sheet(n);
  s.cloths[0].model = model;
  s.cloths[0].material.damping = 1e-5;
  s.cloths[0].material.areal_density = 0.2;  // 1 m²: 0.2 kg
  s.solver.method = "imex";
  s.substeps = 1;
  return s;
}

TEST(Imex, HangingClothIsStableAt60HzWithOneStepPerFrame) {
  // The scene's springs model at its 33 x 33 resolution, and a triangle model (explicit dihedral bending) at
  // 17 x 17 to keep the test short; 3 s each.
  for (const auto& [model, n] : {std::pair<std::string, int>{"springs", 33}, {"corotated_fem", 17}}) {
    Simulation sim(hanging_cloth(model, n));
    const FrameStats s0 = sim.measure();
    const double scale = 0.2 * 9.81 * 1.0;  // J, m g L
    double worst = -1e300, lowest = s0.potential, max_strain = 0.0, late_strain = 0.0, late_rise = -1e300,
           e1 = 0.0;
    FrameStats st;
    for (int f = 0; f < 180; ++f) {  // 3 s
      st = sim.step_frame();
      ASSERT_TRUE(st.finite) << model << " frame " << f;
      const double e = total_energy(st) - total_energy(s0);
      worst = std::max(worst, e);
      lowest = std::min(lowest, st.potential);
      max_strain = std::max(max_strain, st.max_strain);
      if (f == 59) e1 = e;
      if (f >= 60) {
        late_rise = std::max(late_rise, e - e1);
        late_strain = std::max(late_strain, st.max_strain);
      }
    }
    std::printf(
        "imex %s, %d x %d, 60 Hz, 1 step/frame, 3 s: energy rise over the start %.3g J (m g L = %.3g J), "
        "after 1 s over its 1 s value %.3g J; max strain %.4f (after 1 s: %.4f)\n",
        model.c_str(), n, n, worst, scale, late_rise, max_strain, late_strain);
    // Bounded energy: at most a few percent of m g L above the start in the release transient (explicit
    // bending), and after the first second it only decreases (a dissipative scheme); the cloth really fell
    // and swung (its centre of mass went down by more than 0.3 m at some point); strains settle to a few %.
    EXPECT_LT(worst, 0.05 * scale) << model;
    EXPECT_LT(late_rise, 1e-3 * scale) << model;
    EXPECT_LT(lowest, s0.potential - 0.3 * scale) << model;
    EXPECT_LT(max_strain, 0.25) << model;
    EXPECT_LT(late_strain, 0.1) << model;
  }
}

// Mass-weighted RMS distance (m).
double rms(const ClothState& a, const ClothState& b) {
  double num = 0.0, den = 0.0;
  for (int i = 0; i < a.size(); ++i) {
    num += a.mass[i] * (a.x[i] - b.x[i]).squaredNorm();
    den += a.mass[i];
  }
  return std::sqrt(num / den);
}

TEST(Imex, ConvergesFirstOrderToAFineReference) {
  // 9 x 9 springs sheet, 0.25 s; reference: Verlet far below its stability bound (a different, second-order
  // scheme, so IMEX's error is measured against the true trajectory, not against itself).
  auto run = [](const std::string& method, int substeps) {
    SimulationSetup s = hanging_cloth("springs", 9);
    s.cloths[0].material.damping = 0.0;
    s.solver.method = method;
    if (method == "imex") s.solver.params["cg_tolerance"] = 1e-10;
    s.substeps = substeps;
    auto sim = std::make_unique<Simulation>(s);
    for (int f = 0; f < 15; ++f) sim->step_frame();
    return sim;
  };
  const auto ref = run("verlet", 4000);
  std::vector<double> err;
  for (int steps : {16, 32, 64, 128})
    err.push_back(rms(run("imex", steps)->cloths()[0]->state(), ref->cloths()[0]->state()));
  std::printf(
      "imex vs Verlet reference (9 x 9 springs, 0.25 s): RMS error %.3g, %.3g, %.3g, %.3g m at 16, 32, 64, "
      "128 steps per frame (ratios %.2f, %.2f, %.2f)\n",
      err[0], err[1], err[2], err[3], err[0] / err[1], err[1] / err[2], err[2] / err[3]);
  for (size_t k = 0; k + 1 < err.size(); ++k) {
    const double ratio = err[k] / err[k + 1];
    EXPECT_GT(ratio, 1.7) << "halving h from step " << k;
    EXPECT_LT(ratio, 2.4) << "halving h from step " << k;
  }
  EXPECT_LT(err.back(), 1e-2);
}

TEST(Imex, EqualsImplicitEulerWhenEverythingIsStiff) {
  // The springs model on a non-grid mesh has edge and hinge springs; with no bending the hinge springs have
  // k = 0, so IMEX linearises every force there is and must reproduce implicit_euler (up to the CG's
  // round-off); with bending it must differ (the hinge springs are explicit).
  for (double bend : {0.0, 1e-4}) {
    auto step = [&](const std::string& method) {
      SimulationSetup s = test::hanging_sheet(9);
      s.cloths[0].mesh = ClothMesh::from_triangles(s.cloths[0].mesh->rest_positions(),
                                                   s.cloths[0].mesh->triangles(), {}, "test");
      s.cloths[0].material.bend_weft = s.cloths[0].material.bend_warp = bend;
      s.solver.method = method;
      s.solver.params["cg_tolerance"] = 1e-12;
      Simulation sim(s);
      for (int f = 0; f < 10; ++f) sim.step_frame();
      return sim.cloths()[0]->state().x;
    };
    const Vec3s a = step("imex"), b = step("implicit_euler");
    double d = 0.0;
    for (size_t i = 0; i < a.size(); ++i) d = std::max(d, (a[i] - b[i]).norm());
    if (bend == 0.0)
      EXPECT_LT(d, 1e-9);
    else
      EXPECT_GT(d, 1e-6);
  }
}

TEST(Imex, IsRegisteredAndRejectsNewtonIterations) {
  SolverSettings s;
  s.method = "imex";
  s.params["cg_tolerance"] = 1e-5;
  auto solver = make_solver(s, "scene.json");
  EXPECT_STREQ(solver->name(), "imex");
  s.params["newton_iterations"] = 3;
  try {
    make_solver(s, "scene.json");
    FAIL() << "newton_iterations accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("solver.newton_iterations"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace loom::cloth
