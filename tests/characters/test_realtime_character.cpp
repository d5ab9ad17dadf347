// The character scenes in the real-time tier (`"quality": "realtime"`, their shipped setting): over the
// whole clip every frame end has no cloth vertex inside a capsule (loom::collision::max_penetration == 0),
// no intersecting triangle pair in the exact census (self and cloth-cloth), finite positions, and a bounded
// strain; the run is the same with one and two threads.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "loom/collision/MultiClothCensus.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace {

struct Figures {
  int frames = 0;
  long worst_census = 0;
  double depth = 0.0, max_strain = 0.0;
  std::vector<loom::cloth::Vec3s> last;
};

// `max_census`: intersecting pairs allowed at a frame end (0 but where the tier's proximity collision is
// known to give way).
Figures run(const std::string& name, const std::vector<std::string>& sets, int threads = 1,
            long max_census = 0) {
  loom::scene::Scene sc =
      loom::scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/" + name + ".json", sets);
  sc.setup.threads = threads;
  EXPECT_EQ(sc.quality.name, "realtime");
  loom::collision::ColliderSetPtr colliders;
  auto sim = loom::scene::build_simulation(sc, &colliders);
  Figures f;
  for (int k = 1; k <= sc.frames; ++k) {
    const loom::cloth::FrameStats st = sim->step_frame();
    EXPECT_TRUE(st.finite) << name << " frame " << k << ": " << sim->failure();
    if (!st.finite) break;
    std::vector<loom::collision::CensusInput> in;
    for (const auto& c : sim->cloths()) in.push_back({&c->mesh(), &c->state().x});
    const double depth = loom::collision::max_penetration(in, *colliders);
    const long census = loom::collision::count_all_intersections(in, 1);
    EXPECT_EQ(depth, 0.0) << name << " frame " << k << ": a vertex inside a capsule";
    EXPECT_LE(census, max_census) << name << " frame " << k << ": intersecting triangle pairs";
    f.depth = std::max(f.depth, depth);
    f.worst_census = std::max(f.worst_census, census);
    f.max_strain = std::max(f.max_strain, st.max_strain);
    f.frames = k;
  }
  for (const auto& c : sim->cloths()) f.last.push_back(c->state().x);
  std::printf("%-18s %d frames: census worst %ld, depth %.3g m, max strain %.4f\n", name.c_str(), f.frames,
              f.worst_census, f.depth, f.max_strain);
  return f;
}

// The default scene, all 6 s of CMU 01_01. Max strain: the skirt's ring below the attached waist is spread
// by the thighs in the jumps (the reference tier reaches 0.12 there too); the tier's strain limiting holds
// the rest at 10 %.
TEST(RealtimeCharacter, DefaultSceneWholeClip) {
  const Figures f = run("character_layers", {});
  EXPECT_EQ(f.frames, 360);
  EXPECT_LT(f.max_strain, 0.175);
}

// Bounds: the measured max strain (cape 0.187, skirt 0.127) plus a little, so that a regression fails.
TEST(RealtimeCharacter, CapeAndSkirtScenes) {
  for (const auto& [name, strain] : {std::pair<const char*, double>{"character_cape", 0.195},
                                     std::pair<const char*, double>{"character_skirt", 0.135}}) {
    const Figures f = run(name, {});
    EXPECT_EQ(f.frames, 360) << name;
    EXPECT_LT(f.max_strain, strain) << name;
  }
}

// The default scene on the three CMU clips, to each clip's end from the scene's start at 1 s: no vertex
// inside a capsule and no NaN at any frame end. KNOWN GAP: the proximity cloth-cloth collision lets a few
// triangle pairs cross on 01_01 and many on Boxing_Toes (fast punches through the cape), and the skirt's hem
// is stretched between the knees there; the bounds are the measured worst counts and strains, so that a
// regression fails.
TEST(RealtimeCharacter, DefaultSceneOnEveryClipToItsEnd) {
  struct Clip {
    const char* bvh;
    const char* duration;  // s, from the scene's start to the clip's end
    int frames;
    long census;
    double strain;
  };
  for (const Clip& c :
       {Clip{"01_03_8.5s_to_11s.bvh", "1.4", 84, 0, 0.125}, Clip{"01_01.bvh", "21.9", 1314, 7, 0.185},
        Clip{"Boxing_Toes.bvh", "29.6", 1776, 134, 0.64}}) {
    const Figures f = run(
        "character_layers",
        {std::string("character.bvh=../tests/data/mocap/") + c.bvh, std::string("duration=") + c.duration}, 1,
        c.census);
    EXPECT_EQ(f.frames, c.frames) << c.bvh;
    EXPECT_LT(f.max_strain, c.strain) << c.bvh;
  }
}

// The armpit pinch (arms swinging down against the torso three times): the shirt's layers are squeezed
// between arm and torso capsules closer than the proximity allows; the real-time tier keeps every vertex out
// of the capsules but lets a few triangle pairs cross there (the reference tier's impact zones keep 0).
TEST(RealtimeCharacter, ShirtPinchKeepsVerticesOutOfTheCapsules) {
  const Figures f = run("character_shirt", {}, 1, 11);
  EXPECT_EQ(f.frames, 255);
  EXPECT_LT(f.max_strain, 0.135);
}

TEST(RealtimeCharacter, ResultsDoNotDependOnTheThreadCount) {
  const std::vector<std::string> sets = {"duration=0.5"};
  const Figures a = run("character_layers", sets, 1), b = run("character_layers", sets, 2);
  ASSERT_EQ(a.last.size(), b.last.size());
  for (size_t c = 0; c < a.last.size(); ++c)
    for (size_t i = 0; i < a.last[c].size(); ++i)
      ASSERT_EQ(a.last[c][i], b.last[c][i]) << "cloth " << c << " vertex " << i;
}

// The proximity stage's candidate list is a cache: a wider broad-phase padding (rebuilt less often, more
// candidates) gives the same run bit for bit.
TEST(RealtimeCharacter, ResultsDoNotDependOnTheBroadPhasePadding) {
  const Figures a = run("character_layers", {"duration=0.5", "collision.padding=0.005"}),
                b = run("character_layers", {"duration=0.5", "collision.padding=0.1"});
  ASSERT_EQ(a.last.size(), b.last.size());
  for (size_t c = 0; c < a.last.size(); ++c)
    for (size_t i = 0; i < a.last[c].size(); ++i)
      ASSERT_EQ(a.last[c][i], b.last[c][i]) << "cloth " << c << " vertex " << i;
}

}  // namespace
