// The pipeline holds only the stages a setup asks for; pins follow their targets; threads do not change
// results.
#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <memory>

#include "TestUtil.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

SimulationSetup hanging(int n, bool pins, bool drag) {
  SimulationSetup s = test::hanging_sheet(n);
  if (!pins) s.cloths[0].pins.clear();
  if (drag) s.drag = DragSettings{0.1, 0.5, Vec3(1, 0, 0), 0.0, 0.0};
  s.substeps = 40;
  return s;
}

bool has(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

TEST(Pipeline, OnlyTheEffectsTheSetupNamesExist) {
  {
    Simulation sim(hanging(9, false, false));
    const auto names = sim.stage_names();
    EXPECT_FALSE(has(names, "pins"));
    EXPECT_FALSE(has(names, "solve/drag"));
    EXPECT_TRUE(has(names, "solve"));
    EXPECT_TRUE(has(names, "solve/springs"));
    EXPECT_TRUE(has(names, "solve/gravity"));
    EXPECT_EQ(sim.cloths()[0]->find_term("drag"), nullptr);
  }
  {
    Simulation sim(hanging(9, true, true));
    const auto names = sim.stage_names();
    EXPECT_TRUE(has(names, "pins"));
    EXPECT_TRUE(has(names, "solve/drag"));
    EXPECT_NE(sim.cloths()[0]->find_term("drag"), nullptr);
  }
  {
    SimulationSetup s = hanging(9, false, false);
    s.gravity = Vec3::Zero();
    Simulation sim(s);
    EXPECT_FALSE(has(sim.stage_names(), "solve/gravity"));
  }
}

TEST(Pipeline, EveryStageReportsTimeAndCounters) {
  Simulation sim(hanging(9, true, true));
  for (int f = 0; f < 3; ++f) sim.step_frame();
  for (const StageProfile& p : sim.profile()) {
    EXPECT_GE(p.total_ms, 0.0) << p.name;
    if (p.name == "solve") {
      ASSERT_FALSE(p.counters.empty());
      EXPECT_EQ(p.counters[0].second, 3 * 40);
    }
    if (p.name == "pins") {
      EXPECT_EQ(p.counters[0].second, 3 * 40 * 2);
    }
    if (p.name == "solve/springs") {
      EXPECT_EQ(p.counters[0].second, 3 * 40);  // one evaluation per step
    }
  }
}

TEST(Pipeline, PinnedVerticesFollowTheirPath) {
  for (const char* method : {"explicit_euler", "symplectic_euler", "verlet"}) {
    SimulationSetup s = hanging(9, false, false);
    s.solver.method = method;
    const int v = s.cloths[0].mesh->grid_index(4, 0);
    PinSpec p;
    p.vertex = v;
    p.times = {0.0, 0.5, 1.0};
    p.offsets = {Vec3::Zero(), Vec3(0, 0.2, 0), Vec3(0.1, 0.2, 0)};
    s.cloths[0].pins = {p};
    Simulation sim(s);
    const Vec3 start = sim.cloths()[0]->state().x[v];
    for (int f = 0; f < 60; ++f) {
      sim.step_frame();
      const double t = sim.time();
      const Vec3 expected = start + (t <= 0.5 ? Vec3(0, 0.4 * t, 0) : Vec3(0.2 * (t - 0.5), 0.2, 0));
      ASSERT_LT((sim.cloths()[0]->state().x[v] - expected).norm(), 1e-12) << method << " frame " << f;
    }
  }
}

// A stage that raises the stop flag on its first run (as a SIGINT handler would mid-step), and one that
// counts its runs.
class StopRaiser : public Stage {
 public:
  explicit StopRaiser(volatile std::sig_atomic_t* flag) : flag_(flag) {}
  const char* name() const override { return "stop_raiser"; }
  void run(StageContext&) override { *flag_ = 1; }

 private:
  volatile std::sig_atomic_t* flag_;
};
class RunCounter : public Stage {
 public:
  explicit RunCounter(int* runs) : runs_(runs) {}
  const char* name() const override { return "run_counter"; }
  void run(StageContext&) override { ++*runs_; }

 private:
  int* runs_;
};

// A stop request is read after each stage: the stages after the one during which it came do not run, the
// frame is abandoned and the state is the frame's start, with the guard on and off.
TEST(Pipeline, AStopRequestEndsTheStepAfterTheStageDuringWhichItCame) {
  for (const bool guard : {true, false}) {
    SimulationSetup s = hanging(9, true, false);
    s.guard.enabled = guard;
    Simulation sim(s);
    volatile std::sig_atomic_t flag = 0;
    int runs = 0;
    sim.add_stage(std::make_unique<StopRaiser>(&flag));
    sim.add_stage(std::make_unique<RunCounter>(&runs));
    sim.set_stop_flag(&flag);
    const Vec3s start = sim.cloths()[0]->state().x;
    sim.step_frame();
    EXPECT_TRUE(sim.interrupted()) << guard;
    EXPECT_EQ(runs, 0) << guard;
    const Vec3s& x = sim.cloths()[0]->state().x;
    ASSERT_EQ(x.size(), start.size());
    for (size_t i = 0; i < x.size(); ++i) EXPECT_EQ(x[i], start[i]) << guard << " vertex " << i;
  }
}

TEST(Pipeline, ResultsAreBitIdenticalForOneAndTwoThreads) {
  std::vector<Vec3s> results;
  for (int threads : {1, 2, 1}) {
    SimulationSetup s = hanging(17, true, true);
    s.threads = threads;
    Simulation sim(s);
    for (int f = 0; f < 10; ++f) sim.step_frame();
    results.push_back(sim.cloths()[0]->state().x);
  }
  for (size_t i = 0; i < results[0].size(); ++i) {
    ASSERT_EQ(results[0][i], results[1][i]) << "vertex " << i;
    ASSERT_EQ(results[0][i], results[2][i]) << "vertex " << i;
  }
}

TEST(Pipeline, FrameStatsAreConsistent) {
  Simulation sim(hanging(9, true, false));
  const FrameStats s0 = sim.measure();
  EXPECT_EQ(s0.kinetic, 0.0);
  EXPECT_NEAR(s0.max_strain, 0.0, 1e-12);
  const FrameStats s1 = sim.step_frame();
  EXPECT_GT(s1.kinetic, 0.0);
  EXPECT_LT(s1.potential, s0.potential);  // it falls
  EXPECT_TRUE(s1.finite);
  EXPECT_NEAR(s1.time, 1.0 / 60.0, 1e-15);
  EXPECT_EQ(s1.stage_ms.size(), sim.stage_names().size());
}

TEST(Pipeline, RejectsBadSetups) {
  SimulationSetup s = hanging(5, false, false);
  s.cloths[0].material.areal_density = -1.0;
  try {
    Simulation sim(s, "scene.json");
    FAIL() << "negative density accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cloths[0].material.areal_density"), std::string::npos) << e.what();
  }
  s = hanging(5, false, false);
  s.cloths[0].pins = {PinSpec{999, {}, {}, {}}};
  EXPECT_THROW(Simulation(s, "scene.json"), Error);
  s = hanging(5, false, false);
  s.solver.method = "rk99";
  EXPECT_THROW(Simulation(s, "scene.json"), Error);
}

}  // namespace
}  // namespace loom::cloth
