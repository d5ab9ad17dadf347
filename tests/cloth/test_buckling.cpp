// Issue 4 acceptance, immediate buckling: a strip compressed end to end by 5% buckles out of plane within a
// few steps under Choi-Ko, with no compression stored in its sequential (type-1) springs, while the linear
// spring model stores compression; both stay finite at dt = 1/30 s under BDF2.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct BuckleResult {
  double amplitude = 0.0;         // m, largest |y| (out of plane)
  double first_amplitude = 0.0;   // m, the same after the first step
  double worst_compression = 0.0;  // 1, most negative l/L - 1 over structural springs (as a positive number)
  double mean_compression = 0.0;   // 1, mean of max(0, 1 - l/L) over structural springs
  double shortening = 0.0;        // 1, end-to-end shortening imposed
  bool finite = true;
};

// A 20 cm x 2 cm cotton strip (41 x 5 nodes) in the horizontal XZ plane, no gravity, with a 0.1 mm half-sine
// imperfection out of plane (a perfectly flat strip under in-plane loads never leaves it). `at_once`: the
// strip starts shortened end to end by 5% (every node moved towards the middle, the end rows pinned there);
// otherwise the pinned end rows move together by 5% over 0.1 s. BDF2 at dt = 1/30 s with `newton`
// iterations per step (1: the linearised step).
BuckleResult compress_strip(const std::string& model, int steps, bool at_once = false, int newton = 1) {
  const int nu = 41, nv = 5;
  const double length = 0.2, width = 0.02, squeeze = 0.95;
  GridSpec g;
  g.nodes_u = nu;
  g.nodes_v = nv;
  g.size_u = length;
  g.size_v = width;
  g.plane = GridPlane::kXZ;
  g.origin = Vec3::Zero();
  SimulationSetup s;
  ClothSetup c;
  c.mesh = ClothMesh::grid(g);
  c.material = material_preset("cotton");
  c.model = model;
  const Vec3s& rest = c.mesh->rest_positions();
  const double imperfection = 1e-4, ramp = 0.1;  // m, s: the ends reach their 5% over the first 3 steps
  auto start = [&](int v) {
    const Vec3& p = rest[v];
    const double x = at_once ? 0.5 * length + squeeze * (p.x() - 0.5 * length) : p.x();
    return Vec3(x, imperfection * std::sin(kPi * p.x() / length), p.z());
  };
  for (int iv = 0; iv < nv; ++iv)
    for (int iu : {0, nu - 1}) {
      const int v = c.mesh->grid_index(iu, iv);
      const double shift = (iu == 0 ? 0.5 : -0.5) * (1.0 - squeeze) * length;
      if (at_once) c.pins.push_back(PinSpec{v, start(v), {}, {}});
      else c.pins.push_back(PinSpec{v, start(v), {0.0, ramp}, {Vec3::Zero(), Vec3(shift, 0, 0)}});
    }
  s.cloths.push_back(c);
  s.gravity = Vec3::Zero();
  s.solver.method = "bdf2";
  if (newton > 1) s.solver.params["newton_iterations"] = newton;
  s.frame_dt = 1.0 / 30.0;
  s.substeps = 1;
  Simulation sim(s);
  ClothState& st = sim.cloths()[0]->state();
  for (int v = 0; v < st.size(); ++v) st.x[v] = start(v);
  st.x_prev = st.x;
  BuckleResult r;
  for (int k = 0; k < steps; ++k) {
    sim.step_frame();
    if (k == 0)
      for (const Vec3& p : st.x) r.first_amplitude = std::max(r.first_amplitude, std::abs(p.y()));
  }
  r.shortening = 1.0 - squeeze;
  int count = 0;
  for (const SpringDef& d : c.mesh->springs()) {
    if (d.kind != SpringKind::kStructural) continue;
    const double strain = (st.x[d.j] - st.x[d.i]).norm() / d.rest_length - 1.0;
    r.worst_compression = std::max(r.worst_compression, -strain);
    r.mean_compression += std::max(0.0, -strain);
    ++count;
  }
  r.mean_compression /= count;

  for (const Vec3& p : st.x) {
    r.finite = r.finite && p.allFinite();
    r.amplitude = std::max(r.amplitude, std::abs(p.y()));
  }
  return r;
}

TEST(Buckling, ChoiKoStripBucklesOutOfPlaneWithinFiveSteps) {
  // A clamped-clamped strip shortened by δ buckles into w = A/2 (1 - cos 2πx/S) with A = (2/π) √(S δ)
  // (28 mm for S = 0.19 m, δ = 1 cm). BDF2 at dt = 1/30 s, solved to convergence (Newton, 60 iterations):
  // the Choi-Ko force is far from linear over one step (the linearised step overshoots, stretching single
  // springs by tens of percent, README "Fabric tests").
  const double expected = 2.0 / kPi * std::sqrt(0.19 * 0.01);
  for (const bool at_once : {true, false}) {
    const BuckleResult ck = compress_strip("choi_ko", 5, at_once, 60);
    const BuckleResult sp = compress_strip("springs", 5, at_once, 60);
    std::printf("%s: choi_ko amplitude %.4f m after 1 step, %.4f after 5 (elastica %.4f), type-1 compression mean "
                "%.6f, worst %.5f; springs amplitude %.4f, compression mean %.6f, worst %.5f\n",
                at_once ? "shortened at once" : "ends moved over 0.1 s", ck.first_amplitude, ck.amplitude, expected,
                ck.mean_compression, ck.worst_compression, sp.amplitude, sp.mean_compression, sp.worst_compression);
    ASSERT_TRUE(ck.finite);
    ASSERT_TRUE(sp.finite);
    // Out of plane at once: most of the elastica's amplitude after the first step when shortened at once.
    if (at_once) {
      EXPECT_GT(ck.first_amplitude, 0.5 * expected);
    }
    EXPECT_GT(ck.amplitude, 0.7 * expected);
    EXPECT_LT(ck.amplitude, 1.3 * expected);
    // No compression stored in the type-1 springs (the imposed shortening is 5%).
    EXPECT_LT(ck.mean_compression, 1e-4);
    EXPECT_LT(ck.worst_compression, 5e-3);
  }
  // Not asserted (issue 4 acceptance "a linear spring model stores compression" not met, README): the
  // `springs` model stores none either; it folds into a small zig-zag out of plane (amplitude ~6 mm instead
  // of 28), a mode its skip-one bend springs do not see.
}

TEST(Buckling, BothModelsStayFiniteWithTheLinearisedStep) {
  // dt = 1/30 s with the default (linearised) BDF2 step.
  for (const char* model : {"choi_ko", "springs"}) {
    const BuckleResult r = compress_strip(model, 5, true, 1);
    std::printf("%s, linearised BDF2: amplitude %.4f m, type-1 compression mean %.5f, worst %.4f\n", model,
                r.amplitude, r.mean_compression, r.worst_compression);
    EXPECT_TRUE(r.finite) << model;
    EXPECT_LT(r.amplitude, 0.2) << model;  // the strip is 20 cm long
  }
}

}  // namespace
}  // namespace loom::cloth
