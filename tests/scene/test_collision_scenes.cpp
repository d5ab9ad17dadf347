// Self-collision stress scenes (issue 5) at their shipped CI-sized resolution: after every pipeline step the
// exact census finds 0 intersecting triangle pairs (self pairs sharing no vertex, and pairs between cloths),
// the state stays finite and the kinetic energy stays bounded.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "loom/collision/MultiClothCensus.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace {

using namespace loom;

// Runs after the collision stages: the census of the step's end state.
class CensusStage final : public cloth::Stage {
 public:
  const char* name() const override { return "census"; }
  void run(cloth::StageContext& ctx) override {
    std::vector<collision::CensusInput> in;
    for (const auto& c : ctx.cloths) {
      in.push_back({&c->mesh(), &c->state().x});
      finite = finite && c->state().is_finite();
    }
    const long n = collision::count_all_intersections(in, ctx.threads);
    worst = std::max(worst, n);
    if (n > 0 && first_bad_step < 0) first_bad_step = steps;
    ++steps;
  }
  long worst = 0, steps = 0, first_bad_step = -1;
  bool finite = true;
};

struct Outcome {
  long worst = 0, steps = 0, first_bad = -1;
  bool finite = true;
  double max_kinetic = 0.0;  // J
  double mass = 0.0;         // kg
  double contacts = 0.0;
};

Outcome run_scene(const std::string& name, int frames) {
  const scene::Scene sc = scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/" + name + ".json");
  auto sim = scene::build_simulation(sc);
  auto census = std::make_unique<CensusStage>();
  CensusStage* c = census.get();
  sim->add_stage(std::move(census));
  Outcome o;
  for (const auto& cl : sim->cloths())
    for (double m : cl->state().mass) o.mass += m;
  for (int f = 0; f < frames; ++f) {
    const cloth::FrameStats s = sim->step_frame();
    o.max_kinetic = std::max(o.max_kinetic, s.kinetic);
    if (!s.finite) break;
  }
  for (const auto& p : sim->profile())
    if (p.name == "self_collision")
      for (const auto& [k, v] : p.counters)
        if (k == "contacts") o.contacts = v;
  o.worst = c->worst, o.steps = c->steps, o.first_bad = c->first_bad_step, o.finite = c->finite;
  return o;
}

void expect_clean(const Outcome& o, int min_steps) {
  EXPECT_TRUE(o.finite);
  EXPECT_GE(o.steps, min_steps);
  EXPECT_EQ(o.worst, 0) << "first intersecting step " << o.first_bad;
  // Bounded energy: no vertex mass moves faster than 5 m/s on average.
  EXPECT_LT(o.max_kinetic, 0.5 * o.mass * 25.0);
  EXPECT_GT(o.contacts, 0.0);  // the scene does exercise collision
}

TEST(CollisionScenes, TwistingCloth) { expect_clean(run_scene("twisting_cloth", 60), 240); }
TEST(CollisionScenes, LayerStack) { expect_clean(run_scene("layer_stack", 24), 48); }
TEST(CollisionScenes, DrapedLayers) { expect_clean(run_scene("draped_layers", 30), 60); }

}  // namespace
