// The stability suite: every solver against the hard cases, invariants checked after every frame.
//   - all positions finite (a frame the guard rejects is never handed out: the simulation keeps the last
//     good frame and reports the failure with its cause);
//   - energy: E(t) = E_kin + E_el + E_pot(t) - E_pot(0) never above 10 max(E(0), m|g|L) + W(t), where W(t)
//     sums an upper estimate of the work put in from outside (pins: |f·v| of the pinned vertices, wind:
//     |f_drag| (|v| + |wind|), per frame);
//   - max strain max(l/L - 1) below the case's bound (the guard is given the same bound, so a solver that
//     breaks it stops cleanly instead of handing out the frame).
// Each case says, per solver, whether it must survive every frame or must fail cleanly (table kExpected; the
// energy invariant is asserted on the solvers that must survive). The cases with collisions and a character
// are in test_stability_collisions.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>
#include <string>

#include "StabilityExpect.h"
#include "SymplecticSetup.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

struct HardCase {
  std::string name;
  SimulationSetup setup;  // solver.method is set per solver
  int frames = 30;
  double max_strain = 3.0;  // 1, bound of max(l/L - 1) at every frame (invariant and guard limit)
  std::function<void(Simulation&)> prepare;            // after construction (initial state); may be empty
  std::function<void(Simulation&, int)> before_frame;  // before frame f (1-based); may be empty
  std::string load_error;                              // non-empty: building must fail with these words
};

std::shared_ptr<const ClothMesh> grid(int n, double size = 1.0, Vec3 origin = Vec3(-0.5, 1.0, -0.5)) {
  GridSpec g;
  g.nodes_u = g.nodes_v = n;
  g.size_u = g.size_v = size;
  g.origin = origin;
  return ClothMesh::grid(g);
}

// 9x9 cotton sheet, 0.2 kg/m², two corners pinned, 60 Hz with 10 substeps.
SimulationSetup base(int n = 9) {
  SimulationSetup s = loom::test::symplectic_setup();
  ClothSetup c;
  c.mesh = grid(n);
  c.material = material_preset("cotton");
  c.material.areal_density = 0.2;
  c.pins = {PinSpec{c.mesh->grid_index(0, 0), {}, {}, {}}, PinSpec{c.mesh->grid_index(n - 1, 0), {}, {}, {}}};
  s.cloths.push_back(c);
  s.frame_dt = 1.0 / 60.0;
  s.substeps = 10;
  return s;
}

// A triangle mesh of n x n nodes with the cells of column `needle` squeezed to `width` m: needle triangles
// (aspect ratio ~ width / 0.125) in the input. width 0: zero-area triangles.
std::shared_ptr<const ClothMesh> needle_mesh(int n, double width) {
  Vec3s x;
  const double h = 1.0 / (n - 1);
  const int needle = n / 2;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      double u = i * h;
      if (i > needle) u -= h - width;  // columns right of the needle column move left
      x.emplace_back(-0.5 + u, 1.0, -0.5 + j * h);
    }
  std::vector<Tri> tris;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      tris.push_back({a, b, d});
      tris.push_back({a, d, c});
    }
  return ClothMesh::from_triangles(x, tris, {}, width > 0 ? "needle.obj" : "zero_area.obj");
}

HardCase make(const std::string& name, const SimulationSetup& setup, int frames) {
  HardCase c;
  c.name = name;
  c.setup = setup;
  c.frames = frames;
  return c;
}

std::vector<HardCase> hard_cases() {
  std::vector<HardCase> cases;
  {  // stretch stiffness 1e6 N/m at dt = 1/30 s (one step per frame)
    HardCase c = make("stiff_1e6_dt_1_30", base(), 15);
    c.setup.cloths[0].material.stretch_weft = c.setup.cloths[0].material.stretch_warp = 1e6;
    c.setup.cloths[0].material.shear = 1e5;
    c.setup.frame_dt = 1.0 / 30.0;
    c.setup.substeps = 1;
    cases.push_back(c);
  }
  {  // areal density 1e-4 kg/m² (2000x lighter than cotton: stiffness over mass is huge)
    HardCase c = make("light_1em4_kg_m2", base(), 30);
    c.setup.cloths[0].material.areal_density = 1e-4;
    cases.push_back(c);
  }
  {  // 50 m/s wind
    HardCase c = make("wind_50_m_s", base(), 30);
    c.setup.drag = DragSettings{0.05, 2.0, Vec3(50, 0, 0), 0.3, 2.0};
    cases.push_back(c);
  }
  {  // pinned edge, opposite edge pulled out to 3x the size over 0.5 s, held
    HardCase c = make("pulled_to_3x", base(), 45);
    const auto& m = *c.setup.cloths[0].mesh;
    c.setup.cloths[0].pins.clear();
    for (int k = 0; k < 9; ++k) {
      c.setup.cloths[0].pins.push_back(PinSpec{m.grid_index(0, k), {}, {}, {}});
      c.setup.cloths[0].pins.push_back(
          PinSpec{m.grid_index(8, k), {}, {0.0, 0.5}, {Vec3::Zero(), Vec3(2, 0, 0)}});
    }
    c.max_strain = 4.0;  // 2 is the imposed stretch
    cases.push_back(c);
  }
  {  // needle triangles (aspect ~1e-3) in the input
    HardCase c = make("needle_triangles", base(), 30);
    c.setup.cloths[0].mesh = needle_mesh(9, 1.25e-4);
    c.setup.cloths[0].pins = {PinSpec{0, {}, {}, {}}, PinSpec{8, {}, {}, {}}};
    cases.push_back(c);
  }
  {  // zero-area triangles in the input: refused at load, naming the triangle
    HardCase c = make("zero_area_triangles", base(), 1);
    c.load_error = "has zero area (degenerate triangle)";
    cases.push_back(c);
  }
  {  // a start with every vertex within 1 mm (the rest shape is the 1 m sheet): a violent expansion
    HardCase c = make("collapsed_within_1mm", base(), 30);
    c.setup.cloths[0].pins.clear();
    c.prepare = [](Simulation& sim) {
      ClothState& s = sim.cloths()[0]->state();
      const Vec3 centre(0.0, 1.0, 0.0);
      for (int i = 0; i < s.size(); ++i) {
        // Scaled by 1e-3 and folded by a small deterministic bump so the start is not a flat sheet.
        s.x[i] = centre + 1e-3 * (s.x[i] - centre) + Vec3(0, 1e-4 * std::sin(7.0 * i), 0);
        s.x_prev[i] = s.x[i];
      }
    };
    c.max_strain = 3.0;
    cases.push_back(c);
  }
  {  // dt changed mid-run: 10 -> 3 -> 40 -> 10 substeps; explicit Euler, unstable on cotton at 10, from its
     // own stable step (its energy drift grows with h): 1600 -> 800 -> 3200 -> 1600
    HardCase c = make("dt_changed_mid_run", base(), 40);
    c.prepare = [](Simulation& sim) {
      if (sim.setup().solver.method == "explicit_euler") sim.set_substeps(1600);
    };
    c.before_frame = [](Simulation& sim, int f) {
      const bool expl = sim.setup().solver.method == "explicit_euler";
      if (f == 11) sim.set_substeps(expl ? 800 : 3);
      if (f == 21) sim.set_substeps(expl ? 3200 : 40);
      if (f == 31) sim.set_substeps(expl ? 1600 : 10);
    };
    cases.push_back(c);
  }
  return cases;
}

const std::vector<std::string>& kSolvers = test::kStabilitySolvers;

// S: survives every frame with every invariant. F: stops with a clean, named failure (the guard's cause; the
// frames handed out before are finite and within the strain bound; no NaN).
using test::Expect;
using test::F;
using test::S;

// Which solvers must survive each case (S) and which must stop with a clean, named failure (F), in the order
// of kSolvers:                                 expl  sympl verlet impl  bdf2  pbd   xpbd  proj  desbrun
const std::map<std::string, std::vector<Expect>> kExpected = {
    {"stiff_1e6_dt_1_30", /* */ {F, F, F, S, S, S, S, S, S}},
    {"light_1em4_kg_m2", /* */ {F, F, F, S, S, S, S, S, S}},
    {"wind_50_m_s", /* */ {F, S, S, S, S, S, S, S, S}},
    {"pulled_to_3x", /* */ {F, S, S, S, S, F, S, S, S}},
    {"needle_triangles", /* */ {F, F, F, S, S, S, S, S, S}},
    {"collapsed_within_1mm", /* */ {F, S, S, S, S, S, S, S, S}},
    {"dt_changed_mid_run", /* */ {S, S, S, S, S, S, S, S, S}},
};

struct Outcome {
  bool survived = false;
  int frames_done = 0;
  std::string failure;
  double max_energy_ratio = 0.0;  // max of E / (10 max(E(0), m|g|L) + W) over the frames handed out
};

double total_mass(const Simulation& sim) {
  double m = 0.0;
  for (const auto& c : sim.cloths())
    for (double mi : c->state().mass) m += mi;
  return m;
}

double potential(const Simulation& sim) {
  double e = 0.0;
  for (const auto& c : sim.cloths())
    for (int i = 0; i < c->state().size(); ++i)
      e -= c->state().mass[i] * sim.setup().gravity.dot(c->state().x[i]);
  return e;
}

// Upper estimate of the work put in from outside over one frame (header comment).
double external_work(Simulation& sim, double dt) {
  double w = 0.0;
  for (auto& c : sim.cloths()) {
    const ClothState& s = c->state();
    Vec3s f;
    c->compute_forces(s.x, s.v, sim.time(), 1, f);
    for (int i = 0; i < s.size(); ++i)
      if (s.inv_mass[i] == 0.0) w += std::abs(f[i].dot(s.v[i])) * dt;
    if (const Term* drag = c->find_term("drag")) {
      Vec3s fd(s.size(), Vec3::Zero());
      drag->add_forces(EvalContext{s.x, s.v, sim.time(), 1}, fd);
      const double wind = sim.setup().drag->wind.norm() * (1.0 + sim.setup().drag->gust_amplitude);
      for (int i = 0; i < s.size(); ++i) w += fd[i].norm() * (s.v[i].norm() + wind) * dt;
    }
  }
  return w;
}

// Runs one case with one solver, checking the invariants after every frame (gtest failures name the frame).
Outcome run_case(const HardCase& hc, const std::string& solver, bool check_energy) {
  SimulationSetup setup = hc.setup;
  setup.solver.method = solver;
  setup.guard.max_strain = hc.max_strain;
  setup.guard.energy_bound =
      10.0;  // the guard enforces the energy invariant too (Guard.h; its W is the one above)
  Simulation sim(setup, hc.name + ".json");
  if (hc.prepare) hc.prepare(sim);
  FrameStats s0 = sim.measure();
  const double pot0 = potential(sim);
  double bbox = 0.0;
  for (const auto& c : sim.cloths()) {
    const Vec3s& X = c->mesh().rest_positions();
    Vec3 lo = X[0], hi = X[0];
    for (const Vec3& p : X) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    bbox = std::max(bbox, (hi - lo).norm());
  }
  const double e0 = s0.kinetic + s0.elastic;
  const double scale = 10.0 * std::max(e0, total_mass(sim) * sim.setup().gravity.norm() * bbox);
  double work = 0.0;
  Outcome out;
  for (int f = 1; f <= hc.frames; ++f) {
    if (hc.before_frame) hc.before_frame(sim, f);
    const FrameStats s = sim.step_frame();
    for (const auto& c : sim.cloths())
      EXPECT_TRUE(c->state().is_finite()) << hc.name << " " << solver << " frame " << f;
    if (!s.finite) {
      out.failure = sim.failure();
      EXPECT_FALSE(out.failure.empty())
          << hc.name << " " << solver << ": a failed frame must carry its cause";
      EXPECT_EQ(sim.frame(), f - 1) << "the simulation must hold the last good frame";
      return out;
    }
    work += external_work(sim, sim.setup().frame_dt);
    const double e = s.kinetic + s.elastic + potential(sim) - pot0;
    out.max_energy_ratio = std::max(out.max_energy_ratio, e / (scale + work));
    if (check_energy) {
      EXPECT_LE(e, scale + work) << hc.name << " " << solver << " frame " << f
                                 << ": energy above 10x start + work";
    }
    EXPECT_LE(s.max_strain, hc.max_strain) << hc.name << " " << solver << " frame " << f;
    out.frames_done = f;
  }
  out.survived = true;
  return out;
}

class Stability : public ::testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(Stability, SurvivesOrFailsCleanly) {
  static const std::vector<HardCase> cases = hard_cases();
  const HardCase& hc = cases[std::get<0>(GetParam())];
  const std::string& solver = kSolvers[std::get<1>(GetParam())];
  if (!hc.load_error.empty()) {
    // Refused at load, naming the input and the problem: no solver ever sees it.
    try {
      SimulationSetup setup = hc.setup;
      setup.cloths[0].mesh = needle_mesh(9, 0.0);
      setup.solver.method = solver;
      Simulation sim(setup, hc.name + ".json");
      ADD_FAILURE() << "zero-area triangles accepted";
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("zero_area.obj"), std::string::npos) << msg;
      EXPECT_NE(msg.find("triangle "), std::string::npos) << msg;
      EXPECT_NE(msg.find(hc.load_error), std::string::npos) << msg;
    }
    return;
  }
  const Expect want = kExpected.at(hc.name)[std::get<1>(GetParam())];
  const Outcome o = run_case(hc, solver, want == S);
  std::printf("%-22s %-17s %s after %d frames, max E/bound %.3g %s\n", hc.name.c_str(), solver.c_str(),
              o.survived ? "survived" : "FAILED", o.frames_done, o.max_energy_ratio, o.failure.c_str());
  if (want == S) {
    EXPECT_TRUE(o.survived) << hc.name << " " << solver << ": " << o.failure;
  } else {
    EXPECT_FALSE(o.survived) << hc.name << " " << solver << " was expected to fail cleanly (table kExpected)";
  }
}

INSTANTIATE_TEST_SUITE_P(HardCases, Stability,
                         ::testing::Combine(::testing::Range(0, 8),
                                            ::testing::Range(0, static_cast<int>(kSolvers.size()))),
                         [](const ::testing::TestParamInfo<std::tuple<int, int>>& info) {
                           static const std::vector<HardCase> cases = hard_cases();
                           return cases[std::get<0>(info.param)].name + "_" +
                                  kSolvers[std::get<1>(info.param)];
                         });

}  // namespace
}  // namespace loom::cloth
