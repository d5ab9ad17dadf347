// Weil 1986 geometric drape: the catenary construction, a strip hung from two points against the
// analytic catenary sag (Weil 1986; S = 1 m, spans 0.5, 0.8, 0.9 m), a square hung from its four corners
// is symmetric, refusals of what it cannot do.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include "SymplecticSetup.h"
#include "TestUtil.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Simulation.h"
#include "loom/cloth/WeilSolver.h"

namespace loom::cloth {
namespace {

TEST(Weil, CatenaryPointHasTheLengthAndEnds) {
  const Vec3 down(0, -1, 0);
  for (const auto& [a, b, S] : {std::tuple<Vec3, Vec3, double>{Vec3(0, 1, 0), Vec3(0.8, 1, 0), 1.0},
                                {Vec3(0, 1, 0), Vec3(0.3, 1.4, 0.4), 1.2},  // uneven heights, oblique plane
                                {Vec3(0, 1, 0), Vec3(0.0, 0.7, 0.0), 0.9},  // one above the other
                                {Vec3(0, 1, 0), Vec3(0.5, 1, 0), 0.4}}) {   // taut
    EXPECT_LT((catenary_point(a, b, S, 0.0, down) - a).norm(), 1e-12);
    EXPECT_LT((catenary_point(a, b, S, S, down) - b).norm(), 1e-9);
    double len = 0.0;
    Vec3 prev = a;
    for (int k = 1; k <= 10000; ++k) {
      const Vec3 p = catenary_point(a, b, S, S * k / 10000.0, down);
      len += (p - prev).norm();
      prev = p;
    }
    // The vertical case folds back on itself: the polyline cuts the fold by up to two samples.
    const bool folded = std::abs((b - a).x()) + std::abs((b - a).z()) == 0.0;
    EXPECT_NEAR(len, std::max(S, (b - a).norm()), (folded ? 2e-4 : 1e-6) * S);
  }
}

// A strip of length S = 1 m (101 x 2 nodes, 1 cm wide) hung by its two ends at span d.
SimulationSetup strip(double d) {
  SimulationSetup s = loom::test::symplectic_setup();
  ClothSetup c;
  GridSpec g;
  g.size_u = 1.0;
  g.size_v = 0.01;
  g.nodes_u = 101;
  g.nodes_v = 2;
  g.origin = Vec3(-0.5, 1.0, 0.0);
  c.mesh = ClothMesh::grid(g);
  c.model = "baraff_witkin";
  for (int iv = 0; iv < 2; ++iv) {
    c.pins.push_back(PinSpec{c.mesh->grid_index(0, iv), Vec3(-0.5 * d, 1.0, 0.01 * iv), {}, {}});
    c.pins.push_back(PinSpec{c.mesh->grid_index(100, iv), Vec3(0.5 * d, 1.0, 0.01 * iv), {}, {}});
  }
  s.cloths.push_back(c);
  s.solver.method = "weil";
  return s;
}

TEST(Weil, StripMatchesTheAnalyticCatenarySag) {
  // Catenary of length 1 m, y = a cosh(x/a) with S = 2a sinh(d/2a): sag 0.39819 m (d = 0.5), 0.26544 m (0.8),
  // 0.19071 m (0.9).
  for (const auto& [d, sag] : {std::pair<double, double>{0.5, 0.39819}, {0.8, 0.26544}, {0.9, 0.19071}}) {
    Simulation sim(strip(d));
    const auto t0 = std::chrono::steady_clock::now();
    sim.step_frame();
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const ClothState& st = sim.cloths()[0]->state();
    double lowest = 1e9;
    for (const Vec3& p : st.x) lowest = std::min(lowest, p.y());
    const double measured = 1.0 - lowest;
    std::printf("weil strip span %.1f m: sag %.5f m (analytic %.5f, error %.3f%%), %.2f ms\n", d, measured,
                sag, 100.0 * std::abs(measured - sag) / sag, ms);
    EXPECT_NEAR(measured, sag, 0.01 * sag) << "span " << d;
    // The midpoint is the lowest point and the pinned ends did not move.
    const int mid = sim.cloths()[0]->mesh().grid_index(50, 0);
    EXPECT_NEAR(st.x[mid].y(), lowest, 1e-9);
    EXPECT_NEAR(st.x[mid].x(), 0.0, 1e-9);
    EXPECT_LT((st.x[0] - Vec3(-0.5 * d, 1.0, 0.0)).norm(), 1e-12);
    // Static: a second frame keeps the shape, velocities are zero.
    const Vec3s x1 = st.x;
    sim.step_frame();
    for (int i = 0; i < st.size(); ++i) {
      EXPECT_LT((st.x[i] - x1[i]).norm(), 1e-12);
      EXPECT_EQ(st.v[i].norm(), 0.0);
    }
  }
}

TEST(Weil, SquareHungFromFourCornersIsSymmetric) {
  SimulationSetup s = loom::test::symplectic_setup();
  ClothSetup c;
  GridSpec g;
  g.nodes_u = g.nodes_v = 21;
  g.origin = Vec3(-0.5, 1.0, -0.5);
  c.mesh = ClothMesh::grid(g);
  const double h = 0.35;  // corners at (±0.35, 1, ±0.35): span 0.7 m on a 1 m side
  c.pins = {PinSpec{c.mesh->grid_index(0, 0), Vec3(-h, 1, -h), {}, {}},
            PinSpec{c.mesh->grid_index(20, 0), Vec3(h, 1, -h), {}, {}},
            PinSpec{c.mesh->grid_index(0, 20), Vec3(-h, 1, h), {}, {}},
            PinSpec{c.mesh->grid_index(20, 20), Vec3(h, 1, h), {}, {}}};
  s.cloths.push_back(c);
  s.solver.method = "weil";
  Simulation sim(s);
  const auto t0 = std::chrono::steady_clock::now();
  sim.step_frame();
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const ClothMesh& mesh = sim.cloths()[0]->mesh();
  const Vec3s& x = sim.cloths()[0]->state().x;
  double asym = 0.0, lowest = 1e9, highest = -1e9;
  for (int iv = 0; iv < 21; ++iv)
    for (int iu = 0; iu < 21; ++iu) {
      const Vec3& p = x[mesh.grid_index(iu, iv)];
      const Vec3& mu = x[mesh.grid_index(20 - iu, iv)];  // mirror in x
      const Vec3& mv = x[mesh.grid_index(iu, 20 - iv)];  // mirror in z
      const Vec3& sw = x[mesh.grid_index(iv, iu)];       // swap x and z
      asym =
          std::max({asym, (Vec3(-mu.x(), mu.y(), mu.z()) - p).norm(),
                    (Vec3(mv.x(), mv.y(), -mv.z()) - p).norm(), (Vec3(sw.z(), sw.y(), sw.x()) - p).norm()});
      lowest = std::min(lowest, p.y());
      highest = std::max(highest, p.y());
      ASSERT_TRUE(p.allFinite());
    }
  const double centre = 1.0 - x[mesh.grid_index(10, 10)].y();
  std::printf(
      "weil square on 4 corners (21 x 21): centre sag %.4f m, lowest %.4f m, asymmetry %.2g m, %.2f ms\n",
      centre, 1.0 - lowest, asym, ms);
  EXPECT_LT(asym, 1e-9);
  EXPECT_NEAR(highest, 1.0, 1e-12);  // nothing above the corners
  EXPECT_GT(centre, 0.1);            // it hangs: the centre sags below the corners
  // The diagonal carries a catenary of length sqrt(2) m over a 0.99 m span: its sag is the centre's.
  const double S = std::sqrt(2.0), d = 2.0 * std::sqrt(2.0) * h;
  const Vec3 mid = catenary_point(Vec3(-h, 1, -h), Vec3(h, 1, h), S, 0.5 * S, Vec3(0, -1, 0));
  EXPECT_NEAR(centre, 1.0 - mid.y(), 1e-9) << "diagonal span " << d;
}

void expect_refused(SimulationSetup s, const std::string& field) {
  try {
    Simulation sim(s, "scene.json");
    FAIL() << "accepted; expected a refusal naming " << field;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("weil"), std::string::npos) << e.what();
  }
}

TEST(Weil, RefusesScenesThatNeedMotion) {
  SimulationSetup base = strip(0.8);
  {
    SimulationSetup s = base;
    s.drag = DragSettings{};
    expect_refused(s, "effects.drag");
  }
  {
    SimulationSetup s = base;
    s.cloths[0].pins[0].times = {0.0, 1.0};
    s.cloths[0].pins[0].offsets = {Vec3::Zero(), Vec3(0.1, 0, 0)};
    expect_refused(s, "pins[0].path");
  }
  {
    SimulationSetup s = base;
    s.cloths[0].initial_velocity = Vec3(0, 0, 1);
    expect_refused(s, "velocity");
  }
  {
    SimulationSetup s = base;
    s.cloths[0].pins.clear();
    expect_refused(s, "pins");
  }
  {
    SimulationSetup s = base;
    const auto& m = *s.cloths[0].mesh;
    s.cloths[0].mesh = ClothMesh::from_triangles(m.rest_positions(), m.triangles(), {}, "test");
    expect_refused(s, "mesh");
  }
}

// The drape hangs along -y from anchors it can reach: another gravity, anchors farther apart than the
// cloth between them and two vertices at one anchor are refused by field.
TEST(Weil, RefusesGravityOffTheVerticalAndUnreachableAnchors) {
  for (const Vec3& g : {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 9.81, 0), Vec3(0.5, -9.81, 0)}) {
    SimulationSetup s = strip(0.8);
    s.gravity = g;
    expect_refused(s, "gravity");
  }
  {
    SimulationSetup s = strip(0.8);
    s.gravity = Vec3(0, -3.0, 0);  // any magnitude along -y: the catenary shape does not depend on it
    Simulation sim(s, "scene.json");
    EXPECT_TRUE(sim.step_frame().finite);
  }
  {
    SimulationSetup s = strip(1.5);  // ends 1.5 m apart on a 1 m strip
    expect_refused(s, "pins[1].anchor");
  }
  {
    SimulationSetup s = strip(0.8);
    for (auto& p : s.cloths[0].pins) p.anchor = Vec3(0, 1, 0);  // all four corners at one point
    expect_refused(s, "anchor");
  }
}

// The frame statistics of weil drapes, whose hung cloth has compressed edges (vertices hanging straight
// down from one pin fold onto each other): the mean strain counts the stretch the max counts, so
// max_strain >= mean_strain in every frame (a mean of |l/L - 1| was 0.35 with max_strain 0).
TEST(Weil, MaxStrainIsNeverBelowTheMeanStrain) {
  std::vector<SimulationSetup> runs = {strip(0.5), strip(0.8), strip(0.99)};
  SimulationSetup one = strip(0.8);
  one.cloths[0].pins.resize(1);  // one corner: everything hangs straight down from it
  runs.push_back(one);
  SimulationSetup square = strip(0.8);
  GridSpec g;
  g.nodes_u = g.nodes_v = 17;
  g.origin = Vec3(-0.5, 1.0, -0.5);
  square.cloths[0].mesh = ClothMesh::grid(g);
  square.cloths[0].pins = {PinSpec{0, Vec3(-0.3, 1, -0.3), {}, {}}, PinSpec{16, Vec3(0.3, 1, -0.3), {}, {}}};
  runs.push_back(square);
  square.cloths[0].pins.resize(1);
  runs.push_back(square);
  int compressed = 0;
  for (size_t k = 0; k < runs.size(); ++k) {
    Simulation sim(runs[k], "scene.json");
    const FrameStats f0 = sim.measure();
    EXPECT_GE(f0.max_strain, f0.mean_strain) << "run " << k << ", frame 0";
    const FrameStats f1 = sim.step_frame();
    ASSERT_TRUE(f1.finite) << "run " << k << ": " << sim.failure();
    EXPECT_GE(f1.max_strain, f1.mean_strain) << "run " << k;
    EXPECT_GE(f1.mean_strain, 0.0) << "run " << k;
    const auto& x = sim.cloths()[0]->state().x;
    const auto& springs = sim.cloths()[0]->mesh().springs();
    for (int q : sim.cloths()[0]->mesh().strain_springs())
      if ((x[springs[q].j] - x[springs[q].i]).norm() < 0.5 * springs[q].rest_length) {
        ++compressed;
        break;
      }
  }
  EXPECT_GT(compressed, 0);  // the invariant was exercised on drapes with strongly compressed edges
}

// A long narrow grid hung from its four corners folds its long edges' neighbours together: the compressed
// edges hold far more elastic energy than the guard's energy bound (28790 J at 300 x 2), which is no motion
// of the drape. The guard judges the drape by finiteness and strain only, and a rolled-back frame drapes
// again (the retry, left undraped, stopped the run with "the strain exploded").
TEST(Weil, LongNarrowGridDrapesUnderTheGuard) {
  for (int n : {300, 2000}) {
    SimulationSetup s = strip(0.8);
    GridSpec g;
    g.nodes_u = n;
    g.nodes_v = 2;
    g.origin = Vec3(-0.5, 1.5, -0.5);
    s.cloths[0].mesh = ClothMesh::grid(g);
    s.cloths[0].model = "springs";
    const double h = 0.35;
    s.cloths[0].pins = {PinSpec{0, Vec3(-h, 1.5, -h), {}, {}}, PinSpec{n - 1, Vec3(h, 1.5, -h), {}, {}},
                        PinSpec{n, Vec3(-h, 1.5, h), {}, {}}, PinSpec{2 * n - 1, Vec3(h, 1.5, h), {}, {}}};
    ASSERT_TRUE(s.guard.enabled);
    Simulation sim(s, "scene.json");
    const FrameStats f = sim.step_frame();
    ASSERT_TRUE(f.finite) << n << ": " << sim.failure();
    EXPECT_LT(f.max_strain, 1e-6) << n;  // catenaries keep the rows' arc length
    // Restored to the start (as a rollback does), the next step drapes again.
    StateWriter w;
    Simulation fresh(s, "scene.json");
    fresh.save_state(w);
    StateReader in(w.data(), "(test)");
    sim.load_state(in);
    ASSERT_TRUE(sim.step_frame().finite) << n << ": " << sim.failure();
    EXPECT_LT(sim.measure().max_strain, 1e-6) << n;
  }
}

// Anchors the catenaries reach only by stretching the cloth (two corners of a square 1e-8 m apart, the other
// two spread): the frame fails on guard.max_strain at once, with no retry and no word of substeps (the drape
// is one shape at any number of them).
TEST(Weil, AStretchedDrapeFailsWithoutRetriesOrSubsteps) {
  SimulationSetup s = strip(0.8);
  GridSpec g;
  g.nodes_u = g.nodes_v = 33;
  g.origin = Vec3(-0.5, 1.5, -0.5);
  s.cloths[0].mesh = ClothMesh::grid(g);
  s.cloths[0].model = "springs";
  const double h = 0.35;
  s.cloths[0].pins = {PinSpec{0, Vec3(-h, 1.5, -h), {}, {}}, PinSpec{32, Vec3(-h, 1.5, -h + 1e-8), {}, {}},
                      PinSpec{32 * 33, Vec3(-h, 1.5, h), {}, {}},
                      PinSpec{33 * 33 - 1, Vec3(h, 1.5, h), {}, {}}};
  Simulation sim(s, "scene.json");
  EXPECT_FALSE(sim.step_frame().finite);
  EXPECT_NE(sim.failure().find("the strain exploded"), std::string::npos) << sim.failure();
  EXPECT_NE(sim.failure().find("the weil drape's one shape"), std::string::npos) << sim.failure();
  EXPECT_EQ(sim.failure().find("substeps"), std::string::npos) << sim.failure();
  EXPECT_EQ(sim.rollbacks(), 0);
}

// A refusal names the cloth's field with its index (cloths[1].pins[1].anchor), not a template.
TEST(Weil, RefusalNamesTheClothByIndex) {
  SimulationSetup s = strip(0.8);
  SimulationSetup far = strip(1.5);
  s.cloths.push_back(far.cloths[0]);
  s.cloths[1].name = "second";
  try {
    Simulation sim(s, "scene.json");
    FAIL() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("scene.json: cloths[1].pins[1].anchor: "), std::string::npos)
        << e.what();
    EXPECT_EQ(std::string(e.what()).find("cloths[]"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace loom::cloth
