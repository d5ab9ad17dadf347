// The guard's intersection check (collision::IntersectionGuardStage, scene key
// `guard.intersections`): two sheets 5 cm apart with cloth-cloth collision; a test stage before the solver
// pushes a vertex of the upper sheet 10 cm down through the lower one in a given frame, an intersection no
// collision stage can undo (the step starts from it). The guard must find the new pairs (the same pairs as
// the census), roll the frame back and retry it; a push on every try stops the run with "cloth intersections:
// ..." naming the cloths and triangles, the last good frame kept; a push on the first try only is survived.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "loom/cloth/Error.h"
#include "loom/collision/IntersectionGuardStage.h"
#include "loom/collision/MultiClothCensus.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace loom {
namespace {

// Before the solver: in frame `frame` (0-based), moves vertex `vertex` of cloth 0 by `dy` (m); `tries`: how
// many tries of that frame get the push (the guard's retries run the frame again). Not part of the saved
// state, so the retries see how many tries were pushed.
class PushStage final : public cloth::Stage {
 public:
  PushStage(int frame, int vertex, double dy, int tries)
      : frame_(frame), vertex_(vertex), dy_(dy), tries_(tries) {}
  const char* name() const override { return "push"; }
  void run(cloth::StageContext& ctx) override {
    const double f = ctx.t * 60.0;
    // The frame's first step only.
    if (std::abs(f - frame_) > 1e-9 || pushed_ >= tries_) return;
    cloth::ClothState& st = ctx.cloths[0]->state();
    st.x[vertex_].y() += dy_;
    st.x_prev[vertex_].y() += dy_;
    ++pushed_;
  }
  int pushed() const { return pushed_; }

 private:
  int frame_, vertex_;
  double dy_;
  int tries_;
  int pushed_ = 0;
};

std::string two_sheets(bool guard_on) {
  return std::string(R"({
    "duration": 1, "fps": 60, "gravity": [0, 0, 0], "solver": {"method": "implicit_euler", "substeps": 2},
    "guard": {"max_halvings": 2, "intersections": )") +
         (guard_on ? "true" : "false") + R"(},
    "collision": {"self": true},
    "cloths": [{"name": "upper", "mesh": {"type": "grid", "size": [0.4, 0.4], "nodes": [5, 5], "plane": "xz", "origin": [-0.2, 0.05, -0.2]},
                "material": {"preset": "cotton"}, "mass": 0.05},
               {"name": "lower", "mesh": {"type": "grid", "size": [0.4, 0.4], "nodes": [5, 5], "plane": "xz", "origin": [-0.2, 0.0, -0.2]},
                "material": {"preset": "cotton"}, "mass": 0.05}]
  })";
}

std::unique_ptr<cloth::Simulation> build(bool guard_on) {
  const scene::Scene sc = scene::parse_scene(nlohmann::json::parse(two_sheets(guard_on)), "two_sheets.json");
  return scene::build_simulation(sc, nullptr);
}

long census(const cloth::Simulation& sim) {
  std::vector<collision::CensusInput> in;
  for (const auto& c : sim.cloths()) in.push_back({&c->mesh(), &c->state().x});
  return collision::count_all_intersections(in, 1);
}

bool has_stage(const cloth::Simulation& sim, const std::string& name) {
  for (const std::string& n : sim.stage_names())
    if (n == name) return true;
  return false;
}

TEST(IntersectionGuard, PushThroughTheOtherSheetStopsTheRunAtTheLastGoodFrame) {
  auto sim = build(true);
  ASSERT_TRUE(has_stage(*sim, "intersection_guard"));
  auto push = std::make_unique<PushStage>(3, 12, -0.10, 1000);  // the middle vertex of the upper sheet
  PushStage* p = push.get();
  sim->add_stage(std::move(push), cloth::Simulation::Slot::before_solve);
  cloth::StateWriter before;
  cloth::FrameStats st;
  int f = 1;
  for (; f <= 6; ++f) {
    before.clear();
    sim->save_state(before);
    st = sim->step_frame();
    if (!st.finite) break;
    EXPECT_EQ(census(*sim), 0) << "frame " << f;
  }
  ASSERT_FALSE(st.finite) << "the push through the lower sheet was not reported";
  EXPECT_EQ(f, 4);
  EXPECT_EQ(p->pushed(), 3);  // 2 substeps, retried with 4 and 8
  const std::string& why = sim->failure();
  EXPECT_NE(why.find("cloth intersections: "), std::string::npos) << why;
  EXPECT_NE(why.find(" intersecting triangle pairs the step start did not have (triangle "),
            std::string::npos)
      << why;
  EXPECT_NE(why.find(" of cloth 'upper' and triangle "), std::string::npos) << why;
  EXPECT_NE(why.find(" of cloth 'lower')"), std::string::npos) << why;
  EXPECT_NE(why.find("after step 1 of 8 in frame 4"), std::string::npos) << why;
  EXPECT_NE(why.find("also with 8 substeps"), std::string::npos) << why;
  // Exactly the last good frame: no pair, the state saved before the failed frame.
  EXPECT_EQ(sim->frame(), 3);
  EXPECT_EQ(census(*sim), 0);
  cloth::StateWriter after;
  sim->save_state(after);
  EXPECT_EQ(before.data(), after.data());
}

TEST(IntersectionGuard, WithoutTheGuardTheSameRunKeepsTheIntersections) {
  // The same push, `intersections` false: no guard stage, the run goes on with the sheets pierced (what the
  // guard is there to catch).
  auto sim = build(false);
  EXPECT_FALSE(has_stage(*sim, "intersection_guard"));
  sim->add_stage(std::make_unique<PushStage>(3, 12, -0.10, 1000), cloth::Simulation::Slot::before_solve);
  for (int f = 1; f <= 6; ++f) ASSERT_TRUE(sim->step_frame().finite) << sim->failure();
  EXPECT_GT(census(*sim), 0);
}

TEST(IntersectionGuard, AFrameThatPassesOnRetryIsKept) {
  // The push only on the frame's first try: the guard rolls it back, the retry (4 substeps) is clean.
  auto sim = build(true);
  auto push = std::make_unique<PushStage>(3, 12, -0.10, 1);
  PushStage* p = push.get();
  sim->add_stage(std::move(push), cloth::Simulation::Slot::before_solve);
  for (int f = 1; f <= 6; ++f) {
    ASSERT_TRUE(sim->step_frame().finite) << sim->failure();
    EXPECT_EQ(census(*sim), 0) << "frame " << f;
  }
  EXPECT_EQ(p->pushed(), 1);
  EXPECT_EQ(sim->rollbacks(), 1);
  for (const cloth::StageProfile& row : sim->profile())
    if (row.name == "intersection_guard") {
      ASSERT_EQ(row.counters.size(), 4u);
      EXPECT_EQ(row.counters[0].first, "pairs");
      EXPECT_EQ(row.counters[0].second, 0.0);
      EXPECT_EQ(row.counters[1].first, "worst_new");
      EXPECT_GT(row.counters[1].second, 0.0);  // the pushed try
    }
}

TEST(IntersectionGuard, PairsAreTheCensusPairs) {
  // A sheet folded through itself: the pairs found are as many as the census counts, sorted, each
  // intersecting non-adjacent triangles; the guard primed on that state allows exactly those.
  auto sim = build(false);
  cloth::ClothState& up = sim->cloths()[0]->state();
  for (int k : {11, 12, 13}) up.x[k].y() -= 0.10;  // a ridge of the upper sheet through the lower one
  std::vector<collision::CensusInput> in;
  for (const auto& c : sim->cloths()) in.push_back({&c->mesh(), &c->state().x});
  const std::vector<collision::IntersectingPair> pairs = collision::intersecting_pairs(in, 2);
  ASSERT_GT(pairs.size(), 0u);
  EXPECT_EQ(static_cast<long>(pairs.size()), collision::count_all_intersections(in, 1));
  EXPECT_TRUE(std::is_sorted(pairs.begin(), pairs.end()));
  for (const auto& q : pairs) EXPECT_TRUE(q.cloth_a == 0 && q.cloth_b == 1) << q.cloth_a << " " << q.cloth_b;
  collision::IntersectionGuardStage guard;
  guard.prime(sim->cloths(), 1);
  EXPECT_EQ(guard.pairs(), pairs);
  std::vector<std::unique_ptr<cloth::Cloth>>& cloths = sim->cloths();
  cloth::StageContext ctx{cloths, 0.0, 1.0 / 120, 1};
  guard.run(ctx);  // nothing moved: the tangle of the start is allowed
  EXPECT_EQ(guard.violation(), "");
  // One more vertex through: new pairs, a violation; restoring the saved allowance and running on the old
  // state again is clean (the guard's rollback).
  cloth::StateWriter saved;
  guard.save_state(saved);
  const cloth::Vec3 keep = up.x[7];
  up.x[7].y() -= 0.10;
  guard.run(ctx);
  EXPECT_NE(guard.violation().find("cloth intersections: "), std::string::npos) << guard.violation();
  up.x[7] = keep;
  cloth::StateReader r(saved.data(), "(test)");
  guard.load_state(r);
  EXPECT_EQ(guard.violation(), "");
  guard.run(ctx);
  EXPECT_EQ(guard.violation(), "");
  // A cut-short archive fails loudly.
  cloth::StateReader bad(saved.data().substr(0, saved.data().size() - 4), "(cut)");
  EXPECT_THROW(guard.load_state(bad), Error);
}

TEST(IntersectionGuard, SelfIntersectionNamesTheCloth) {
  // One sheet, self-collision only: a corner vertex pushed through the sheet's middle, the message names
  // the cloth and both triangles.
  const scene::Scene sc = scene::parse_scene(nlohmann::json::parse(R"({
    "duration": 1, "fps": 60, "gravity": [0, 0, 0], "solver": {"method": "implicit_euler", "substeps": 2},
    "guard": {"intersections": true},
    "collision": {"self": true},
    "cloths": [{"name": "skirt", "mesh": {"type": "grid", "size": [0.4, 0.4], "nodes": [5, 5], "plane": "xz", "origin": [-0.2, 0.0, -0.2]},
                "material": {"preset": "cotton"}, "mass": 0.05}]
  })"),
                                             "one_sheet.json");
  auto sim = scene::build_simulation(sc, nullptr);
  collision::IntersectionGuardStage guard;
  guard.prime(sim->cloths(), 1);
  cloth::ClothState& st = sim->cloths()[0]->state();
  // Vertex 0 (corner at (-0.2, 0, -0.2)) folded over to (0.05, -0.05, 0.05), its edges now pierce the middle.
  st.x[0] = cloth::Vec3(0.05, -0.05, 0.05);
  st.x[1] = cloth::Vec3(0.0, 0.05, 0.05);
  cloth::StageContext ctx{sim->cloths(), 0.0, 1.0 / 120, 1};
  guard.run(ctx);
  const std::string& why = guard.violation();
  EXPECT_NE(why.find("cloth intersections: "), std::string::npos) << why;
  EXPECT_NE(why.find("(cloth 'skirt': triangles "), std::string::npos) << why;
}

}  // namespace
}  // namespace loom
