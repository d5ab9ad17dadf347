// Immediate buckling (Choi & Ko 2002): a strip compressed end to end by 5% buckles out of plane within a
// few steps under Choi-Ko, with no compression stored in its sequential (type-1) springs, while the linear
// spring model stores compression; both stay finite at dt = 1/30 s under BDF2.
//
// Which linear-spring set-up stores compression (docs/validation.md, "Immediate buckling"): a linear spring
// pushes back under compression as hard as it pulls, so the flat compressed strip is an equilibrium, unstable
// (buckling). Whether a step leaves it depends on how the implicit step treats that instability:
//  - the linearised BDF2 step with the exact spring Jacobian (Baraff & Witkin 1998 publish the exact K;
//    solver.clamp_compression = 0): for γ²|λ| > m the step maps the growing buckling mode back onto the flat
//    state, so the strip stays flat and keeps the whole 5% (the rubber-like response Choi & Ko describe:
//    "the instability caused by buckling ... cannot be avoided by simply employing a semi-implicit method");
//  - the clamped Jacobian (Blender's, our default) drops the compressed springs' negative
//    transverse stiffness from A, so their transverse push acts explicitly: growth ~ h² k ε / m ~ 10⁴ per
//    step, the strip buckles within one step (overshooting to ~27 N at the ends without the safeguard);
//  - an exactly solved step (Newton) minimises the incremental potential and leaves the saddle as well.
// In the last two the `springs` strip ends in a small out-of-plane zig-zag (alternate node columns up and
// down): distance springs cannot see that mode (with the structural springs at rest every pair in adjacent
// columns is at rest, and skip-one pairs join nodes on the same side), a limit of mass-spring bending, not a
// bug to fix here (releasing the whole 5% that way takes a 36° kink at every node, which a hinge-angle
// bending model would charge). No damping either: along-spring damping slows the release for both models
// alike (Choi-Ko's slack type-1 springs are damped too), so it shows no contrast.
// The test below therefore runs each model with the Jacobian its source prescribes: the linear springs with
// the exact one, Choi-Ko with its own (the buckling springs' transverse term dropped, as Choi & Ko and
// Blender's fbstar_jacobi do), both with the default linearised BDF2 step and safeguard; the clamped linear
// springs are measured too (they buckle, storing nothing).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "SymplecticSetup.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct StepRecord {
  double amplitude = 0.0;          // m, largest |y| (out of plane)
  double mean_compression = 0.0;   // 1, mean of max(0, 1 - l/L) over the structural springs along the strip
  double worst_compression = 0.0;  // 1, largest 1 - l/L over the same springs
  bool finite = true;
};

// A 20 cm x 2 cm cotton strip (41 x 5 nodes) in the horizontal XZ plane, no gravity, with a 0.1 mm half-sine
// imperfection out of plane (a perfectly flat strip under in-plane loads never leaves it). `at_once`: the
// strip starts shortened end to end by 5% (every node moved towards the middle, the end rows pinned there);
// otherwise the pinned end rows move together by 5% over 0.1 s. BDF2 at dt = 1/30 s with `newton`
// iterations per step (1: the linearised step) and the solver's clamp_compression. One record per step.
// Compression is measured over the structural springs along the strip (the direction of the imposed 5%).
std::vector<StepRecord> compress_strip(const std::string& model, int steps, bool at_once, int newton,
                                       bool clamp = true) {
  const int nu = 41, nv = 5;
  const double length = 0.2, width = 0.02, squeeze = 0.95;
  GridSpec g;
  g.nodes_u = nu;
  g.nodes_v = nv;
  g.size_u = length;
  g.size_v = width;
  g.plane = GridPlane::kXZ;
  g.origin = Vec3::Zero();
  SimulationSetup s = loom::test::symplectic_setup();
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
      if (at_once)
        c.pins.push_back(PinSpec{v, start(v), {}, {}});
      else
        c.pins.push_back(PinSpec{v, start(v), {0.0, ramp}, {Vec3::Zero(), Vec3(shift, 0, 0)}});
    }
  s.cloths.push_back(c);
  s.gravity = Vec3::Zero();
  s.solver.method = "bdf2";
  if (newton > 1) s.solver.params["newton_iterations"] = newton;
  if (!clamp) s.solver.params["clamp_compression"] = 0;
  s.frame_dt = 1.0 / 30.0;
  s.substeps = 1;
  Simulation sim(s);
  ClothState& st = sim.cloths()[0]->state();
  for (int v = 0; v < st.size(); ++v) st.x[v] = start(v);
  st.x_prev = st.x;
  std::vector<StepRecord> out;
  for (int k = 0; k < steps; ++k) {
    sim.step_frame();
    StepRecord r;
    int count = 0;
    for (const SpringDef& d : c.mesh->springs()) {
      if (d.kind != SpringKind::kStructural || std::abs(d.rest_uv_dir.x()) < 0.5) continue;
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
    out.push_back(r);
  }
  return out;
}

void print(const char* label, const std::vector<StepRecord>& rs) {
  std::printf("%s:", label);
  for (size_t k = 0; k < rs.size(); ++k)
    std::printf(" [%zu] %.1f mm %.4f%%/%.3f%%", k + 1, 1e3 * rs[k].amplitude, 100 * rs[k].mean_compression,
                100 * rs[k].worst_compression);
  std::printf("  (amplitude, compression mean/worst)\n");
}

// A clamped-clamped strip shortened by δ buckles into w = A/2 (1 - cos 2πx/S) with A = (2/π) √(S δ)
// (28 mm for S = 0.19 m, δ = 1 cm).
const double kElastica = 2.0 / kPi * std::sqrt(0.19 * 0.01);

TEST(Buckling, LinearSpringsStoreTheCompressionChoiKoBucklesAtDefaultSettings) {
  // Shortened by 5% at once, 5 linearised BDF2 steps of 1/30 s (the default step, safeguard on).
  const auto sp = compress_strip("springs", 5, true, 1, /*clamp=*/false);
  const auto ck = compress_strip("choi_ko", 5, true, 1);
  const auto sp_clamped = compress_strip("springs", 5, true, 1);
  print("springs, exact Jacobian", sp);
  print("choi_ko", ck);
  print("springs, clamped Jacobian", sp_clamped);
  for (size_t k = 0; k < sp.size(); ++k) {
    ASSERT_TRUE(sp[k].finite && ck[k].finite && sp_clamped[k].finite) << "step " << k + 1;
    // The linear springs stay flat and keep the compression after every step: ≥ 90% of the imposed 5%.
    EXPECT_GT(sp[k].mean_compression, 0.045) << "step " << k + 1;
    EXPECT_LT(sp[k].amplitude, 1e-3) << "step " << k + 1;
  }
  // Choi-Ko: out of plane within two steps, near the elastica after five, nothing stored: mean compression
  // < 0.1% (2% of the imposed 5%), worst spring < 2%.
  EXPECT_GT(ck[1].amplitude, 0.7 * kElastica);
  EXPECT_GT(ck.back().amplitude, 0.7 * kElastica);
  EXPECT_LT(ck.back().amplitude, 1.3 * kElastica);
  EXPECT_LT(ck.back().mean_compression, 1e-3);
  EXPECT_LT(ck.back().worst_compression, 2e-2);
  // The clamped linear springs buckle too (see the comment at the top): nothing stored after one step.
  EXPECT_LT(sp_clamped.front().mean_compression, 1e-3);
}

TEST(Buckling, ChoiKoStripBucklesOutOfPlaneWithinFiveStepsWhenSolvedToConvergence) {
  // BDF2 at dt = 1/30 s solved to convergence (Newton, 60 iterations), both set-ups.
  for (const bool at_once : {true, false}) {
    const auto ck = compress_strip("choi_ko", 5, at_once, 60);
    print(at_once ? "choi_ko, Newton, shortened at once" : "choi_ko, Newton, ends moved over 0.1 s", ck);
    for (const StepRecord& r : ck) ASSERT_TRUE(r.finite);
    // Out of plane at once: most of the elastica's amplitude after the first step when shortened at once.
    if (at_once) {
      EXPECT_GT(ck.front().amplitude, 0.5 * kElastica);
    }
    EXPECT_GT(ck.back().amplitude, 0.7 * kElastica);
    EXPECT_LT(ck.back().amplitude, 1.3 * kElastica);
    // No compression stored in the type-1 springs (the imposed shortening is 5%).
    EXPECT_LT(ck.back().mean_compression, 1e-4);
    EXPECT_LT(ck.back().worst_compression, 5e-3);
  }
}

}  // namespace
}  // namespace loom::cloth
