// Determinism, state save/restore and the guard, per solver on the cloth API:
//   - the same setup and thread count gives bit-identical frames (FNV-1a hash of every frame's x and v);
//   - 1 and 2 threads give the same hash (all reductions are per element, then gathered in fixed order);
//   - save_state after k frames, load into a fresh simulation, continue: bit-identical to not stopping;
//   - a run that never rolls back is bit-identical with the guard on and off; a frame the guard rejects is
//     retried with more substeps and the run goes on; a hopeless one stops at the last good frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>

#include "SymplecticSetup.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

const std::vector<std::string> kSolvers = {
    "explicit_euler", "symplectic_euler", "verlet", "implicit_euler", "bdf2", "pbd",
    "xpbd",           "projective",       "desbrun"};

void hash_bytes(std::uint64_t& h, const void* data, size_t n) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;  // FNV-1a
}

void hash_state(std::uint64_t& h, const Simulation& sim) {
  for (const auto& c : sim.cloths()) {
    hash_bytes(h, c->state().x.data(), c->state().x.size() * sizeof(Vec3));
    hash_bytes(h, c->state().v.data(), c->state().v.size() * sizeof(Vec3));
  }
}

// A pinned sheet of n x n nodes with drag and a moving pin, a small start bump: every stage runs.
SimulationSetup sheet(const std::string& solver, int n, int threads) {
  SimulationSetup s = loom::test::symplectic_setup();
  ClothSetup c;
  GridSpec g;
  g.nodes_u = g.nodes_v = n;
  g.origin = Vec3(-0.5, 1.0, -0.5);
  c.mesh = ClothMesh::grid(g);
  c.material = material_preset("cotton");
  c.material.areal_density = 0.2;
  c.pins = {PinSpec{c.mesh->grid_index(0, 0), {}, {}, {}},
            PinSpec{c.mesh->grid_index(n - 1, 0), {}, {0.0, 0.2}, {Vec3::Zero(), Vec3(0.05, 0.1, 0.0)}}};
  s.cloths.push_back(c);
  s.drag = DragSettings{0.05, 1.0, Vec3(3, 0, 1), 0.3, 1.5};
  s.solver.method = solver;
  s.substeps = solver == "explicit_euler" ? 400 : solver == "symplectic_euler" || solver == "verlet" ? 40 : 4;
  s.threads = threads;
  return s;
}

std::uint64_t run_hash(const SimulationSetup& setup, int frames, long* rollbacks = nullptr) {
  Simulation sim(setup);
  std::uint64_t h = 1469598103934665603ull;
  hash_state(h, sim);
  for (int f = 0; f < frames; ++f) {
    const FrameStats s = sim.step_frame();
    EXPECT_TRUE(s.finite) << setup.solver.method << " frame " << f + 1 << ": " << sim.failure();
    hash_state(h, sim);
  }
  if (rollbacks) *rollbacks = sim.rollbacks();
  return h;
}

class Determinism : public ::testing::TestWithParam<std::string> {};

// Explicit Euler gains energy every step (docs/references.md, "Time integration"): a few frames only, before
// the guard steps in.
int frames_for(const std::string& solver, int frames) { return solver == "explicit_euler" ? 2 : frames; }

TEST_P(Determinism, SameThreadsSameHash) {
  const SimulationSetup s = sheet(GetParam(), 9, 1);
  EXPECT_EQ(run_hash(s, frames_for(GetParam(), 10)), run_hash(s, frames_for(GetParam(), 10)));
}

TEST_P(Determinism, OneAndTwoThreadsSameHash) {
  // Implicit solvers on 48x48 nodes: above the filtered PCG's one-thread threshold (2048 vertices), so every
  // loop runs parallel; the others parallelise every loop at any size (17x17).
  const bool pcg = GetParam() == "implicit_euler" || GetParam() == "bdf2";
  const int n = pcg ? 48 : 17, frames = frames_for(GetParam(), 3);
  EXPECT_EQ(run_hash(sheet(GetParam(), n, 1), frames), run_hash(sheet(GetParam(), n, 2), frames));
}

TEST_P(Determinism, SaveAndLoadStateContinuesBitIdentically) {
  const SimulationSetup s = sheet(GetParam(), 9, 1);
  Simulation a(s);
  const int k = frames_for(GetParam(), 6);
  for (int f = 0; f < k; ++f) a.step_frame();
  StateWriter saved;
  a.save_state(saved);
  std::uint64_t ha = 1469598103934665603ull;
  for (int f = 0; f < k; ++f) {
    a.step_frame();
    hash_state(ha, a);
  }
  Simulation b(s);  // fresh: the solver has no history until it is loaded
  StateReader in(saved.data(), "memory");
  b.load_state(in);
  EXPECT_EQ(b.frame(), k);
  EXPECT_DOUBLE_EQ(b.time(), a.time() - k * s.frame_dt);
  std::uint64_t hb = 1469598103934665603ull;
  for (int f = 0; f < k; ++f) {
    b.step_frame();
    hash_state(hb, b);
  }
  EXPECT_EQ(ha, hb);
}

TEST_P(Determinism, GuardOffAndOnAreBitIdenticalWithoutRollbacks) {
  SimulationSetup on = sheet(GetParam(), 9, 1), off = on;
  off.guard.enabled = false;
  long rollbacks = -1;
  EXPECT_EQ(run_hash(on, frames_for(GetParam(), 8), &rollbacks), run_hash(off, frames_for(GetParam(), 8)));
  EXPECT_EQ(rollbacks, 0);
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, Determinism, ::testing::ValuesIn(kSolvers),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

TEST(Guard, RejectedFrameIsRetriedWithMoreSubstepsAndTheRunGoesOn) {
  // Symplectic Euler just above its stability limit at 6 substeps: the frame explodes, 12 or 24 substeps
  // hold; the counters say so and no frame handed out is bad.
  SimulationSetup s = sheet("symplectic_euler", 9, 1);
  s.drag.reset();
  s.cloths[0].material.stretch_weft = s.cloths[0].material.stretch_warp = 2e4;
  s.substeps = 6;
  Simulation sim(s);
  for (int f = 0; f < 20; ++f) {
    const FrameStats st = sim.step_frame();
    ASSERT_TRUE(st.finite) << sim.failure();
    ASSERT_TRUE(sim.cloths()[0]->state().is_finite());
  }
  EXPECT_GT(sim.rollbacks(), 0);
  bool found = false;
  for (const StageProfile& p : sim.profile())
    if (p.name == "guard") {
      found = true;
      EXPECT_EQ(p.counters[0].first, "rollbacks");
      EXPECT_EQ(p.counters[0].second, sim.rollbacks());
    }
  EXPECT_TRUE(found);
}

TEST(Guard, HopelessFrameStopsAtTheLastGoodFrameWithItsCause) {
  SimulationSetup s = sheet("explicit_euler", 9, 1);
  s.substeps = 1;
  s.guard.max_halvings = 2;
  Simulation sim(s);
  StateWriter before;
  FrameStats st;
  int f = 0;
  for (; f < 50; ++f) {
    before.clear();
    sim.save_state(before);
    st = sim.step_frame();
    if (!st.finite) break;
  }
  ASSERT_FALSE(st.finite);
  EXPECT_NE(sim.failure().find("exploded"), std::string::npos) << sim.failure();
  EXPECT_NE(sim.failure().find("frame " + std::to_string(f + 1)), std::string::npos) << sim.failure();
  EXPECT_NE(sim.failure().find("also with 4 substeps"), std::string::npos) << sim.failure();
  StateWriter after;
  sim.save_state(after);
  EXPECT_EQ(before.data(), after.data());  // exactly the last good frame
}

TEST(Guard, NonFiniteStateIsNamedAsSuch) {
  GuardSettings g;
  GuardSample a, b;
  b.finite = false;
  EXPECT_NE(guard_violation(g, a, b, 1.0).find("non-finite"), std::string::npos);
  b = a;
  b.kinetic = 1e9;
  EXPECT_NE(guard_violation(g, a, b, 1.0).find("energy exploded"), std::string::npos);
  b = a;
  b.elastic = 1e9;  // stretch counts as much as motion
  EXPECT_NE(guard_violation(g, a, b, 1.0).find("energy exploded"), std::string::npos);
  b = a;
  b.max_strain = 11.0;
  EXPECT_NE(guard_violation(g, a, b, 1.0).find("strain exploded"), std::string::npos);
  b = a;
  b.kinetic = 50.0;  // within 100 x (0 + 0 + 0 + 1 J)
  EXPECT_EQ(guard_violation(g, a, b, 1.0), "");
}

// A stage that reports a violation after every step longer than `max_h` (s) that starts at or after `from_t`
// (s): the guard must treat it like an explosion (roll back, retry with smaller steps, stop with its cause
// when none is small enough).
class StepLimitStage final : public Stage {
 public:
  explicit StepLimitStage(double max_h, double from_t = 0.0) : max_h_(max_h), from_t_(from_t) {}
  const char* name() const override { return "step_limit"; }
  void run(StageContext& ctx) override {
    ++steps;
    why_ = ctx.h > max_h_ && ctx.t >= from_t_ ? "step too long for the test stage" : "";
  }
  std::string violation() const override { return why_; }
  long steps = 0;

 private:
  double max_h_, from_t_;
  std::string why_;
};

TEST(Guard, StageViolationIsRetriedWithSmallerSteps) {
  SimulationSetup s = sheet("implicit_euler", 5, 1);
  s.substeps = 1;
  Simulation sim(s);
  auto stage = std::make_unique<StepLimitStage>(s.frame_dt / 3.0);  // needs 4 substeps: two halvings
  StepLimitStage* sl = stage.get();
  sim.add_stage(std::move(stage));
  for (int f = 1; f <= 3; ++f) {
    const FrameStats st = sim.step_frame();
    ASSERT_TRUE(st.finite) << sim.failure();
    EXPECT_EQ(sim.frame(), f);
  }
  EXPECT_EQ(sim.rollbacks(),
            6);  // each frame: 1 substep (stopped after its step), 2 substeps (after the 1st), 4
  EXPECT_EQ(sl->steps, 3 * (1 + 1 + 4));
}

TEST(Guard, StageViolationThatNoStepCuresStopsTheRunWithItsCause) {
  SimulationSetup s = sheet("bdf2", 5, 1);
  s.substeps = 2;
  s.guard.max_halvings = 2;
  Simulation sim(s);
  sim.add_stage(std::make_unique<StepLimitStage>(0.0, 0.99 * s.frame_dt));  // frame 1 passes, frame 2 cannot
  ASSERT_TRUE(sim.step_frame().finite) << sim.failure();
  StateWriter before;
  sim.save_state(before);
  const FrameStats st = sim.step_frame();
  EXPECT_FALSE(st.finite);
  EXPECT_EQ(sim.frame(), 1);
  EXPECT_NE(sim.failure().find("step too long for the test stage after step 1 of 8 in frame 2"),
            std::string::npos)
      << sim.failure();
  EXPECT_NE(sim.failure().find("also with 8 substeps"), std::string::npos) << sim.failure();
  StateWriter after;
  sim.save_state(after);
  EXPECT_EQ(before.data(), after.data());  // exactly frame 1: nothing of the failed frame is kept
}

// A stage that claims `per_step` J of work put in per step (Stage::work_in()).
class WorkStage final : public Stage {
 public:
  explicit WorkStage(double per_step) : per_step_(per_step) {}
  const char* name() const override { return "work"; }
  void run(StageContext&) override { work_ += per_step_; }
  double work_in() const override { return work_; }
  void save_state(StateWriter& out) const override { out.f64(work_); }
  void load_state(StateReader& in) override { work_ = in.f64(); }

 private:
  double per_step_, work_ = 0.0;
};

TEST(Guard, EnergyBudgetCountsStartEnergyAndWorkPutIn) {
  // A free sheet thrown up at 10 m/s: E(t) = E_kin + E_el + E_pot - E_pot(0) stays at most E_kin(0) = ½ m 100
  // (the fall trades kinetic for potential energy; implicit Euler only loses some). With the budget at
  // 1x max(E(0), m|g|L) it holds; at 0.5x it stops at once, naming the budget; work a stage claims to put
  // in widens the budget again.
  SimulationSetup s = sheet("implicit_euler", 5, 1);
  s.drag.reset();
  s.cloths[0].pins.clear();
  s.cloths[0].initial_velocity = Vec3(0, 10, 0);
  s.substeps = 4;
  s.guard.energy_bound = 1.0;
  {
    Simulation sim(s);
    for (int f = 0; f < 10; ++f) ASSERT_TRUE(sim.step_frame().finite) << sim.failure();
  }
  s.guard.energy_bound = 0.5;
  double m = 0.0;
  {
    Simulation probe(s);
    for (double mi : probe.cloths()[0]->state().mass) m += mi;
  }
  const double e0 = 0.5 * m * 100.0, weight = m * 9.81 * std::sqrt(2.0);
  ASSERT_GT(e0, 0.5 * std::max(e0, weight) + 1e-9);
  {
    Simulation sim(s);
    EXPECT_FALSE(sim.step_frame().finite);
    EXPECT_NE(sim.failure().find("above the budget"), std::string::npos) << sim.failure();
    EXPECT_EQ(sim.frame(), 0);
  }
  {
    Simulation sim(s);
    sim.add_stage(std::make_unique<WorkStage>(e0));  // claims E(0) of work per step: enough
    for (int f = 0; f < 5; ++f) ASSERT_TRUE(sim.step_frame().finite) << sim.failure();
  }
}

TEST(StateArchive, CutShortOrMismatchedArchivesAreErrors) {
  SimulationSetup s = sheet("bdf2", 5, 1);
  Simulation sim(s);
  sim.step_frame();
  StateWriter w;
  sim.save_state(w);
  const std::string cut = w.data().substr(0, w.data().size() / 2);
  StateReader r1(cut, "cut.bin");
  try {
    Simulation(s).load_state(r1);
    FAIL() << "a cut archive was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cut.bin"), std::string::npos) << e.what();
  }
  SimulationSetup other = sheet("bdf2", 7, 1);
  StateReader r2(w.data(), "other.bin");
  EXPECT_THROW(Simulation(other).load_state(r2), Error);
}

}  // namespace
}  // namespace loom::cloth
