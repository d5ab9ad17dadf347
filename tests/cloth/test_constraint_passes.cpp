// Constraint passes after the solver: Provot strain limiting and long-range tethers.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "TestUtil.h"
#include "loom/cloth/Simulation.h"
#include "loom/cloth/StrainLimitStage.h"
#include "loom/cloth/TetherStage.h"

namespace loom::cloth {
namespace {

// A soft sheet (so it stretches a lot under gravity) hanging from two corners.
SimulationSetup soft_sheet(int n, double stretch) {
  SimulationSetup s = test::hanging_sheet(n);
  Material& m = s.cloths[0].material;
  m.stretch_weft = m.stretch_warp = stretch;
  m.shear = 0.5 * stretch;
  m.damping = 0.01;
  s.solver.method = "symplectic_euler";
  s.substeps = 20;
  return s;
}

bool has(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

// Largest l/L - 1 over the structural and shear springs.
double max_stretch(const Cloth& c) {
  double m = -1.0;
  for (const SpringDef& d : c.mesh().springs())
    if (d.kind == SpringKind::kStructural || d.kind == SpringKind::kShear)
      m = std::max(m, (c.state().x[d.j] - c.state().x[d.i]).norm() / d.rest_length - 1.0);
  return m;
}

TEST(ConstraintPasses, StagesExistOnlyWhenNamed) {
  SimulationSetup s = soft_sheet(5, 100.0);
  {
    Simulation sim(s);
    EXPECT_FALSE(has(sim.stage_names(), "strain_limit"));
    EXPECT_FALSE(has(sim.stage_names(), "tethers"));
  }
  s.strain_limit = StrainLimitSettings{};
  s.tethers = TetherSettings{};
  Simulation sim(s);
  const auto names = sim.stage_names();
  ASSERT_TRUE(has(names, "strain_limit"));
  ASSERT_TRUE(has(names, "tethers"));
  // After the solver, in the documented order.
  const auto at = [&](const char* n) { return std::find(names.begin(), names.end(), n) - names.begin(); };
  EXPECT_LT(at("solve"), at("strain_limit"));
  EXPECT_LT(at("strain_limit"), at("tethers"));
}

TEST(ConstraintPasses, ProvotLeavesNoSpringAboveTheLimitOnAStretchedCloth) {
  Simulation sim(soft_sheet(9, 100.0));
  Cloth& cloth = *sim.cloths()[0];
  ClothState& s = cloth.state();
  // Stretch the free vertices by 60% away from pin 0, and shake them.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.02, 0.02);
  const Vec3 origin = s.x[0];
  s.x_prev = s.x;
  for (int i = 0; i < s.size(); ++i)
    if (s.inv_mass[i] > 0.0) s.x[i] = origin + 1.6 * (s.x[i] - origin) + Vec3(u(rng), u(rng), u(rng));
  const Vec3s pinned_before = {s.x[0], s.x[8]};
  ASSERT_GT(max_stretch(cloth), 0.5);
  StrainLimitStage stage(StrainLimitSettings{0.1, 5000});
  const double h = 0.01;
  StageContext ctx{sim.cloths(), 0.0, h, 1};
  stage.run(ctx);
  EXPECT_LE(max_stretch(cloth), 0.1 + 1e-9);
  EXPECT_EQ(stage.remaining_violations(), 0);
  EXPECT_EQ(s.x[0], pinned_before[0]);  // kinematic vertices never move
  EXPECT_EQ(s.x[8], pinned_before[1]);
  // Velocity correction: v = (x_corr - x_prev) / h for the moved vertices.
  for (int i : {40, 80}) EXPECT_LT((s.v[i] - (s.x[i] - s.x_prev[i]) / h).norm(), 1e-9);
}

TEST(ConstraintPasses, ProvotReportsRemainingViolationsWithFewIterations) {
  Simulation sim(soft_sheet(9, 100.0));
  ClothState& s = sim.cloths()[0]->state();
  const Vec3 origin = s.x[0];
  for (int i = 0; i < s.size(); ++i)
    if (s.inv_mass[i] > 0.0) s.x[i] = origin + 1.6 * (s.x[i] - origin);
  StrainLimitStage stage(StrainLimitSettings{0.1, 1});
  StageContext ctx{sim.cloths(), 0.0, 0.01, 1};
  stage.run(ctx);
  EXPECT_GT(stage.remaining_violations(), 0);
}

TEST(ConstraintPasses, ProvotCountsASpringBetweenVerticesPinnedAfterTheFirstRun) {
  // Springs between two kinematic vertices are never corrected, so they are counted as remaining when
  // stretched, also when the vertices became kinematic after an earlier run.
  Simulation sim(soft_sheet(9, 100.0));
  ClothState& s = sim.cloths()[0]->state();
  StrainLimitStage stage(StrainLimitSettings{0.1, 5000});
  StageContext ctx{sim.cloths(), 0.0, 0.01, 1};
  s.x_prev = s.x;
  stage.run(ctx);
  EXPECT_EQ(stage.remaining_violations(), 0);
  // Pin vertex 1 (vertex 0, its neighbour in the first row, is pinned) 50% of the edge beyond its rest place.
  s.inv_mass[1] = 0.0;
  s.x[1] = s.x[0] + 1.5 * (s.x[1] - s.x[0]);
  s.x_prev = s.x;
  stage.run(ctx);
  EXPECT_GE(stage.remaining_violations(), 1);
  EXPECT_EQ(stage.remaining_violations(), 1);  // the free neighbours were brought within the limit
}

// limit_stretch with held vertices: a held vertex is kinematic for the limit (its neighbour moves all the
// way), a spring with both ends held shares the correction by inverse mass; the sweeps stop once one
// corrected nothing, with the same result as running all of them.
TEST(ConstraintPasses, LimitStretchMovesTheFreeEndOfAHeldVertex) {
  Simulation sim(soft_sheet(9, 100.0));
  Cloth& cloth = *sim.cloths()[0];
  ClothState& s = cloth.state();
  const double rest = (s.x[1] - s.x[0]).norm();
  // Out of the sheet's plane by 0.6 spring lengths: the springs at vertex 70 reach sqrt(1.36) - 1 = 17 %,
  // and 40, 41 (joined by a spring) go opposite ways.
  const Vec3 normal = (s.x[1] - s.x[0]).cross(s.x[9] - s.x[0]).normalized();
  s.x[70] += 0.6 * rest * normal;
  s.x[40] += 0.6 * rest * normal;
  s.x[41] -= 0.6 * rest * normal;
  ASSERT_GT(max_stretch(cloth), 0.15);
  const Vec3s start = s.x;
  std::vector<char> held(s.size(), 0);
  for (int i : {40, 41, 70}) held[i] = 1;
  const std::vector<int> springs = limited_springs(cloth.mesh());
  std::vector<int> moved(s.size(), 0);
  const long corrections = limit_stretch(cloth.mesh(), springs, 0.1, 5000, held, s, moved);
  EXPECT_GT(corrections, 0);
  EXPECT_LE(max_stretch(cloth), 0.1 + 1e-9);
  EXPECT_EQ(s.x[0], start[0]);    // kinematic
  EXPECT_EQ(s.x[70], start[70]);  // held, and no spring joins it to another held vertex
  EXPECT_EQ(moved[70], 0);
  EXPECT_GT(moved[69], 0);  // its neighbour followed
  // 40 and 41 are held and joined: that spring's correction moves both.
  EXPECT_NE(s.x[40], start[40]);
  EXPECT_GT(moved[40], 0);
  // The sweeps stopped after one without correction: more sweeps change nothing.
  const Vec3s converged = s.x;
  std::vector<int> again(s.size(), 0);
  EXPECT_EQ(limit_stretch(cloth.mesh(), springs, 0.1, 5000, held, s, again), 0);
  EXPECT_TRUE(s.x == converged);
}

TEST(ConstraintPasses, StrainLimitedRunStaysNearTheLimit) {
  SimulationSetup s = soft_sheet(9, 30.0);  // so soft it sags by far more than 10% without the pass
  FrameStats free_run, limited_run;
  {
    Simulation sim(s);
    for (int f = 0; f < 40; ++f) free_run = sim.step_frame();
  }
  s.strain_limit = StrainLimitSettings{0.1, 20};
  Simulation sim(s);
  double worst = 0.0;
  for (int f = 0; f < 40; ++f) {
    limited_run = sim.step_frame();
    worst = std::max(worst, limited_run.max_strain);
  }
  EXPECT_TRUE(limited_run.finite);
  EXPECT_GT(free_run.max_strain, 0.3);
  EXPECT_LT(worst, 0.1 + 1e-3);
}

TEST(ConstraintPasses, TethersHold) {
  SimulationSetup s = soft_sheet(9, 30.0);
  double free_excess = 0.0;
  {
    // Without tethers the soft sheet stretches past the tether lengths (so the check below can fail).
    s.tethers.reset();
    Simulation sim(s);
    for (int f = 0; f < 40; ++f) sim.step_frame();
    const ClothState& st = sim.cloths()[0]->state();
    const Vec3s& rest = sim.cloths()[0]->mesh().rest_positions();
    for (int i = 0; i < st.size(); ++i) {
      if (st.inv_mass[i] == 0.0) continue;
      const double d = std::min((rest[i] - rest[0]).norm(), (rest[i] - rest[8]).norm());
      free_excess =
          std::max(free_excess, std::min((st.x[i] - st.x[0]).norm(), (st.x[i] - st.x[8]).norm()) - d);
    }
  }
  EXPECT_GT(free_excess, 0.05);
  for (bool geodesic : {true, false}) {
    s.tethers = TetherSettings{0.0, geodesic};
    Simulation sim(s);
    for (int f = 0; f < 40; ++f) ASSERT_TRUE(sim.step_frame().finite);
    const ClothState& st = sim.cloths()[0]->state();
    const Vec3s& rest = sim.cloths()[0]->mesh().rest_positions();
    // Every free vertex is tethered, to its nearest pin, and no tether is longer than its rest length.
    int tethered = 0;
    for (const auto& p : sim.profile())
      if (p.name == "tethers")
        for (const auto& c : p.counters)
          if (c.first == "tethers") tethered = static_cast<int>(c.second);
    EXPECT_EQ(tethered, st.size() - 2);
    for (int i = 0; i < st.size(); ++i) {
      if (st.inv_mass[i] == 0.0) continue;
      const int a = (rest[i] - rest[0]).norm() <= (rest[i] - rest[8]).norm() ? 0 : 8;
      const double euclid = (rest[i] - rest[a]).norm();
      // Geodesic rest distance along structural + shear springs is at least the straight distance and at
      // most 8.3% longer (octagonal metric of the grid graph).
      const double bound = geodesic ? euclid * 1.0824 : euclid;
      EXPECT_LE((st.x[i] - st.x[a]).norm(), bound * (1.0 + 1e-12) + 1e-12) << "vertex " << i;
    }
  }
}

}  // namespace
}  // namespace loom::cloth

namespace loom::cloth {
namespace {

// The accuracy benchmark's sheet configuration at a smaller size: cotton, 0.2 kg, two corners pinned,
// fast_xpbd at `substeps` substeps of one iteration, which alone stretches the springs far past 8 %.
SimulationSetup fast_sheet(int n, int substeps) {
  SimulationSetup s = test::hanging_sheet(n);
  s.solver.method = "fast_xpbd";
  s.solver.params = {{"iterations", 1}};
  s.substeps = substeps;
  s.guard.enabled = false;
  return s;
}

// The structural springs' largest l/L - 1 over `frames` frames (FrameStats::max_strain), -1 if a frame
// was not finite.
double worst_strain(const SimulationSetup& s, int frames) {
  Simulation sim(s);
  double worst = 0.0;
  for (int f = 0; f < frames; ++f) {
    const FrameStats st = sim.step_frame();
    if (!st.finite || !sim.cloths()[0]->state().is_finite()) return -1.0;
    worst = std::max(worst, st.max_strain);
  }
  return worst;
}

TEST(ConstraintPasses, OutwardStrainLimitHoldsTheFastSheetWithinTheBound) {
  // The benchmark's configuration (16 substeps, one outward sweep at 8 %), and two sweeps.
  for (const auto& [substeps, sweeps] : {std::pair<int, int>{16, 1}, {16, 2}}) {
    SimulationSetup s = fast_sheet(32, substeps);
    const double free_run = worst_strain(s, 30);
    s.strain_limit = StrainLimitSettings{0.08, sweeps, true};
    const double limited = worst_strain(s, 30);
    EXPECT_GT(free_run, 0.2) << substeps;
    ASSERT_GE(limited, 0.0) << substeps;  // finite throughout
    EXPECT_LT(limited, 0.0913) << substeps;
    EXPECT_GT(limited, 0.0713) << substeps;
  }
}

}  // namespace
}  // namespace loom::cloth
