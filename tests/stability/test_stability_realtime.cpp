// The real-time tier (`"quality": "realtime"`) on the stability suite's hard cases: a character clip at 3x
// speed, a cloth crushed in a shrinking box, and bodies thrown through a hanging sheet at 20 m/s. Each case
// survives every frame or stops with a named cause (the guard's), and for every frame it hands out: every
// position finite and no cloth vertex inside a collider (loom::collision::max_penetration == 0, the tier's
// postcondition). The exact census at each frame's end is printed: the tier gives up exact cloth-cloth
// collision, and these coarse cloths (8 cm edges) folded hard, crushed or hit at 20 m/s do cross themselves.
#include <gtest/gtest.h>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "loom/collision/MultiClothCensus.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace loom {
namespace {

struct RealtimeCase {
  std::string name;
  std::string scene;  // JSON; "@MOCAP" is the mocap folder
  int frames = 60;
  bool must_survive = true;
};

std::vector<RealtimeCase> cases() {
  std::vector<RealtimeCase> c;
#ifdef LOOM_HAVE_CHARACTERS
  c.push_back({"character_clip_at_3x", R"({
      "quality": "realtime", "duration": 1, "fps": 60,
      "collision": {"self": true},
      "constraints": {"tethers": {"slack": 0.1}},
      "character": {"bvh": "@MOCAP/01_01.bvh", "start": 1.0, "speed": 3.0,
                    "garments": [{"type": "cape", "name": "cape", "material": {"preset": "cotton", "damping": 1e-4}, "resolution": 0.08}]}
    })",
               60, true});
#endif
  c.push_back({"crushed_in_shrinking_box_to_50_cm", R"({
      "quality": "realtime", "duration": 1, "fps": 60,
      "collision": {"self": true},
      "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [1, 1], "nodes": [13, 13], "plane": "xz", "origin": [-0.5, 0.3, -0.5]},
                  "material": {"preset": "cotton"}, "mass": 0.2}],
      "colliders": [
        {"name": "floor", "shape": "plane", "thickness": 0.005},
        {"name": "lid", "shape": "plane", "thickness": 0.005, "rotation": {"axis": [1, 0, 0], "degrees": 180},
         "motion": {"keyframes": [{"t": 0, "position": [0, 0.6, 0]}, {"t": 0.4667, "position": [0, 0.25, 0]}]}},
        {"name": "east", "shape": "plane", "thickness": 0.005, "rotation": {"axis": [0, 0, 1], "degrees": 90},
         "motion": {"keyframes": [{"t": 0, "position": [0.6, 0, 0]}, {"t": 0.4667, "position": [0.25, 0, 0]}]}},
        {"name": "west", "shape": "plane", "thickness": 0.005, "rotation": {"axis": [0, 0, 1], "degrees": -90},
         "motion": {"keyframes": [{"t": 0, "position": [-0.6, 0, 0]}, {"t": 0.4667, "position": [-0.25, 0, 0]}]}},
        {"name": "north", "shape": "plane", "thickness": 0.005, "rotation": {"axis": [1, 0, 0], "degrees": -90},
         "motion": {"keyframes": [{"t": 0, "position": [0, 0, 0.6]}, {"t": 0.4667, "position": [0, 0, 0.25]}]}},
        {"name": "south", "shape": "plane", "thickness": 0.005, "rotation": {"axis": [1, 0, 0], "degrees": 90},
         "motion": {"keyframes": [{"t": 0, "position": [0, 0, -0.6]}, {"t": 0.4667, "position": [0, 0, -0.25]}]}}]
    })",
               48, true});
  c.push_back({"bodies_thrown_at_20_m_s", R"({
      "quality": "realtime", "duration": 1, "fps": 60,
      "collision": {"self": true},
      "cloths": [{"name": "curtain", "mesh": {"type": "grid", "size": [0.8, 0.8], "nodes": [17, 17], "plane": "xy", "origin": [-0.4, 0.6, 0.0]},
                  "material": {"preset": "cotton"}, "mass": 0.13, "pins": [{"grid_edge": "v1"}]}],
      "colliders": [
        {"name": "capsule", "shape": "capsule", "radius": 0.05, "half_height": 0.1, "rotation": {"axis": [0, 0, 1], "degrees": 90},
         "motion": {"keyframes": [{"t": 0.0, "position": [-0.15, 1.05, -0.3]}, {"t": 0.03, "position": [-0.15, 1.05, 0.3]}]}},
        {"name": "ball", "shape": "sphere", "radius": 0.06,
         "motion": {"keyframes": [{"t": 0.1, "position": [0.2, 0.9, 0.3]}, {"t": 0.13, "position": [0.2, 0.9, -0.3]}]}}]
    })",
               40, true});
  return c;
}

class RealtimeHardCases : public ::testing::TestWithParam<int> {};

TEST_P(RealtimeHardCases, SurviveOrStopWithANamedCause) {
  const RealtimeCase cc = cases()[GetParam()];
  std::string text = cc.scene;
  const std::string mocap = std::string(LOOM_TEST_DATA) + "/mocap";
  for (size_t p; (p = text.find("@MOCAP")) != std::string::npos;) text.replace(p, 6, mocap);
  const scene::Scene sc = scene::parse_scene(nlohmann::json::parse(text), cc.name + ".json");
  ASSERT_EQ(sc.setup.solver.method, "fast_xpbd");
  collision::ColliderSetPtr colliders;
  auto sim = scene::build_simulation(sc, &colliders);
  long worst = 0;
  int done = 0;
  double depth = 0.0;
  for (int f = 1; f <= cc.frames; ++f) {
    const cloth::FrameStats s = sim->step_frame();
    if (!s.finite) {
      EXPECT_FALSE(sim->failure().empty()) << cc.name << ": a failed frame must carry its cause";
      EXPECT_EQ(sim->frame(), f - 1) << "the simulation must hold the last good frame";
      break;
    }
    std::vector<collision::CensusInput> in;
    for (const auto& c : sim->cloths()) {
      ASSERT_TRUE(c->state().is_finite()) << cc.name << " frame " << f;
      in.push_back({&c->mesh(), &c->state().x});
    }
    if (colliders && !colliders->empty()) {
      const double d = collision::max_penetration(in, *colliders);
      depth = std::max(depth, d);
      EXPECT_EQ(d, 0.0) << cc.name << " frame " << f << ": a vertex inside a collider";
    }
    worst = std::max(worst, collision::count_all_intersections(in, 1));
    done = f;
  }
  std::printf("%-34s %s after %d frames, worst census %ld, depth %.3g m %s\n", cc.name.c_str(),
              done == cc.frames ? "survived" : "STOPPED", done, worst, depth, sim->failure().c_str());
  if (cc.must_survive) {
    EXPECT_EQ(done, cc.frames) << cc.name << ": " << sim->failure();
  }
}

INSTANTIATE_TEST_SUITE_P(Realtime, RealtimeHardCases, ::testing::Range(0, static_cast<int>(cases().size())),
                         [](const ::testing::TestParamInfo<int>& i) { return cases()[i.param].name; });

}  // namespace
}  // namespace loom
