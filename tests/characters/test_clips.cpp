// Short runs of the character scenes at CI resolution: no NaN, bounded strain and vertex speed,
// attached vertices on their bones, and no free vertex inside a capsule by more than the cloth thickness.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <iostream>
#include <set>

#include "loom/characters/Character.h"
#include "loom/characters/ClipProbe.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace {

using namespace loom::characters;

struct RunFigures {
  double max_strain = 0.0, ms_per_frame = 0.0;
  loom::characters::ProbeFigures probe;  // measured at every pipeline step (ClipProbe.h)
  long rollbacks = 0;
  int frames = 0, frames_asked = 0;
};

// Runs `seconds` of a shipped character scene with ClipProbe after every other stage; `census_every`: run the
// exact intersection census every n-th step (0: never).
RunFigures run_scene(const std::string& scene_name, double seconds,
                     const std::vector<std::string>& extra = {}, int census_every = 0) {
  std::vector<std::string> overrides = {"duration=" + std::to_string(seconds)};
  overrides.insert(overrides.end(), extra.begin(), extra.end());
  const loom::scene::Scene scene =
      loom::scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/" + scene_name + ".json", overrides);
  EXPECT_TRUE(scene.character);
  loom::collision::ColliderSetPtr colliders;
  auto sim = loom::scene::build_simulation(scene, &colliders);
  EXPECT_EQ(colliders->size(), scene.character->rig.bones().size());
  auto probe = std::make_unique<ClipProbe>(scene.character, census_every);
  const ClipProbe* p = probe.get();
  sim->add_stage(std::move(probe));
  RunFigures f;
  f.frames_asked = scene.frames;
  const auto start = std::chrono::steady_clock::now();
  for (int frame = 0; frame < scene.frames; ++frame) {
    const auto stats = sim->step_frame();
    EXPECT_TRUE(stats.finite) << scene_name << " frame " << frame << ": " << sim->failure();
    if (!stats.finite) break;
    f.max_strain = std::max(f.max_strain, stats.max_strain);
    ++f.frames;
  }
  f.ms_per_frame =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() /
      scene.frames;
  f.rollbacks = sim->rollbacks();
  f.probe = p->figures();
  std::cout << scene_name << ": " << f.frames << " frames, " << f.probe.steps << " steps, max strain "
            << f.max_strain << ", max speed " << f.probe.max_speed
            << " m/s, deepest free vertex in a capsule " << f.probe.max_depth
            << " m (attached: " << f.probe.max_attached_depth << " m), attachment error " << f.probe.max_track
            << " m, census worst " << f.probe.max_intersections << " over " << f.probe.census_steps
            << " steps, " << f.ms_per_frame << " ms/frame, " << f.rollbacks << " rollbacks\n";
  return f;
}

constexpr double kThickness = 0.001;  // m, cotton's `thickness`: the tolerance of "inside a capsule"

void expect_sane(const RunFigures& f, double strain_bound) {
  EXPECT_EQ(f.frames, f.frames_asked);       // ran to the end
  EXPECT_TRUE(f.probe.finite);               // no NaN at any step
  EXPECT_LT(f.max_strain, strain_bound);     // no run-away stretching (tethers at 10% slack, cotton)
  EXPECT_LT(f.probe.max_speed, 25.0);        // m/s; the fastest limbs of these clips move at a few m/s
  EXPECT_LE(f.probe.max_track, 1e-3);        // attached vertices on their bones (1 mm) at every step
  EXPECT_LE(f.probe.max_depth, kThickness);  // no free vertex deeper inside a capsule than the thickness
  EXPECT_LE(f.probe.max_attached_depth, kThickness);  // nor an attached one (a garment pinned inside a limb)
}

// The hardest seconds of each clip at CI size (0.08 m), found by running the whole clips with
// loom_bench_character_clips (bench/results/character_clips.txt: the t_* columns give the clip time of the
// worst strain, speed and depth): 01_01 around 10.5-13 s, 01_03 around 9.4 s (a shipped excerpt of it),
// Boxing_Toes around 9-10.5 s for the cape.
TEST(CharacterClips, CapeOnJumpingCmu_01_01) {
  expect_sane(
      run_scene("character_cape", 2.0, {"character.start=10.5", "character.garments.0.resolution=0.08"}),
      0.5);
}

TEST(CharacterClips, SkirtOnJumpingCmu_01_01) {
  expect_sane(
      run_scene("character_skirt", 2.5, {"character.start=10.5", "character.garments.0.resolution=0.08"}),
      0.5);
}

// CMU 01_03 from 8.5 s to 11 s (tests/data/mocap/01_03_8.5s_to_11s.bvh): the subject bends over the skirt's
// waist ring (the spine capsule came 3 cm inside the pinned ring before the ring cleared the torso over the
// whole motion).
TEST(CharacterClips, SkirtOnCmu_01_03_BendingOver) {
  expect_sane(run_scene("character_skirt", 2.4,
                        {"character.bvh=../tests/data/mocap/01_03_8.5s_to_11s.bvh", "character.start=0",
                         "character.garments.0.resolution=0.08"}),
              0.5);
}

// Punches and footwork (Boxing_Toes, a Biovision skeleton): fast arms and legs against the garment. This test
// was disabled (strain 5.7, 176 m/s, a vertex 7 cm inside the thigh at the knee) until the capsules became
// rigidly attached to their joint frames (Bone::turn): the Biovision legs point along -y, where the
// shortest-arc rotation computed every substep flipped its twist, so the thigh's surface spun at ~50 m/s.
TEST(CharacterClips, CapeOnBoxing) {
  expect_sane(run_scene("character_cape", 2.0,
                        {"character.bvh=../tests/data/mocap/Boxing_Toes.bvh", "character.start=8.8",
                         "character.garments.0.resolution=0.08"}),
              0.5);
}

TEST(CharacterClips, SkirtOnBoxing) {
  expect_sane(run_scene("character_skirt", 2.0,
                        {"character.bvh=../tests/data/mocap/Boxing_Toes.bvh", "character.start=2.0",
                         "character.garments.0.resolution=0.08"}),
              0.5);
}

// KNOWN GAP, disabled: Boxing_Toes around 24 s (high knees and punches to the body). A window fits its skirt
// at its own start, where the left knee is raised, and the left elbow lies inside the pinned ring there, so
// the attached-depth bound fails (docs/characters.md).
TEST(CharacterClips, DISABLED_SkirtOnBoxingHighKnees) {
  expect_sane(run_scene("character_skirt", 1.5,
                        {"character.bvh=../tests/data/mocap/Boxing_Toes.bvh", "character.start=23.8",
                         "character.garments.0.resolution=0.08"}),
              0.5);
}

// Attached vertices cannot be pushed out of a capsule: the garments are made so that no capsule of the fitted
// rig comes closer than the thickness to an attached vertex over the whole clip (skirt, cape and layers on
// 01_01 and Boxing_Toes from CMU frame 1 to the end, sampled at 240 Hz, the rate of the scenes' substeps). A
// round skirt ring as wide as its widest need put the 01_03 waist ring 2.3 cm inside the upper arm
// (whole-clip run).
TEST(CharacterClips, AttachedVerticesClearEveryCapsuleOverWholeClips) {
  for (const char* clip : {"01_01.bvh", "Boxing_Toes.bvh"})
    for (const char* name : {"character_skirt", "character_cape", "character_layers"}) {
      std::vector<std::string> sets = {std::string("character.bvh=../tests/data/mocap/") + clip,
                                       "character.start=0.008333", "character.garments.0.resolution=0.08"};
      if (std::string(name) == "character_layers") sets.push_back("character.garments.1.resolution=0.08");
      const loom::scene::Scene scene =
          loom::scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/" + name + ".json", sets);
      const Character& c = *scene.character;
      ASSERT_FALSE(c.attachments.empty());
      const double span = c.motion.duration() - c.motion.settings().start;
      double worst = -1.0, when = 0.0;
      std::vector<Transform> pose;
      for (double t = 0.0; t <= span; t += 1.0 / 240.0) {
        c.motion.pose(t, pose);
        for (const Attachment& a : c.attachments) {
          const loom::cloth::Vec3 x = c.target(a, pose);
          for (const Bone& b : c.rig.bones()) {
            const loom::cloth::Vec3 p = pose[b.joint].translation(), d = pose[b.child].translation() - p;
            const double u = std::clamp((x - p).dot(d) / d.squaredNorm(), 0.0, 1.0);
            const double depth = b.radius - (x - p - u * d).norm();
            if (depth > worst) worst = depth, when = t;
          }
        }
      }
      EXPECT_LE(worst, kThickness) << name << " on " << clip << ": an attached vertex " << worst
                                   << " m inside a capsule at " << when << " s";
    }
}

// Skirt + cape as layers with self- and cloth-cloth collision: the exact census after every pipeline step.
TEST(CharacterClips, LayersOnJumpingCmu_01_01_CensusEveryStep) {
  const RunFigures f = run_scene("character_layers", 1.5,
                                 {"character.start=13.0", "character.garments.0.resolution=0.08",
                                  "character.garments.1.resolution=0.08"},
                                 1);
  expect_sane(f, 0.5);
  EXPECT_EQ(f.probe.census_steps, f.probe.steps);
  EXPECT_EQ(f.probe.max_intersections, 0);
}

// Armpits: a loose shirt while both arms rise and swing down against the torso three times (the whole
// synthetic clip tests/data/mocap/arm_swing.bvh), census after every step: no intersection, no explosion,
// no vertex pushed inside the arm or torso capsules.
TEST(CharacterClips, ShirtArmSwingPinch) {
  const RunFigures f = run_scene("character_shirt", 4.25, {"character.garments.0.resolution=0.08"}, 1);
  expect_sane(f, 0.5);
  EXPECT_EQ(f.probe.max_intersections, 0);
  EXPECT_GT(f.probe.census_steps, 1000);
}

}  // namespace
