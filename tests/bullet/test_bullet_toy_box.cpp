// Bodies in a Bullet world never pass through a BulletCloth: the toy box (a corner-tied cloth, twelve small
// boxes, spheres and capsules dropped on it, a kinematic paddle sweeping through them) and the other Bullet
// scenes, run as `loom run` runs them (BulletScene with the scene's tier: "quality": "realtime", the bridge's
// coupled tier; the setup tier pinned by kSetupTier). Every
// frame each body's centre is checked against the cloth's surface (ClothSide.h); the cloth's deepest vertex
// inside a body and its largest edge strain are tracked.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <utility>

#include "ClothSide.h"
#include "loom/bullet/BulletCloth.h"
#include "loom/bullet/BulletScene.h"
#include "loom/scene/Scene.h"
#include "loom/scene/ScenePipeline.h"

namespace loom::test {
namespace {

struct WorldRun {
  int bodies_through = 0;
  int frames = 0;
  double max_strain = 0.0;  // 1
  double max_pen = 0.0;     // m, deepest cloth vertex inside a body at a frame end
  double thickness = 0.0;   // m, the cloth's contact thickness
  double cloth_ms = 0.0;    // ms per frame, the cloth pipeline (mean)
  double worst_ms = 0.0;    // ms, the slowest frame's cloth pipeline
  bool finite = true;
  int round_border = 0;  // side changes (ray parity) with no surface crossing: round the cloth's border
  std::vector<double> final_y;  // m
  bool coupled = false;         // the run was in the bridge's coupled tier
  long cloth_steps = 0;         // cloth pipeline steps over the run (adaptive)
};

// The bridge's setup tier with the scenes' former solver: implicit Euler at the Bullet step.
const std::vector<std::string> kSetupTier = {
    "quality=reference", R"(solver={"method": "implicit_euler", "dt": 0.004166666666666667})"};

WorldRun run_world(const std::string& name, std::vector<std::string> sets = {}, int frames = -1) {
  if (const char* e = std::getenv("LOOM_TOY_SET")) {
    std::stringstream ss(e);
    for (std::string s; std::getline(ss, s, ';');) sets.push_back(s);
  }
  const scene::Scene sc = scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/" + name, sets);
  bullet::BulletScene bs(sc.setup, sc.bodies, scene::bullet_scene_options(sc));
  // Kinematic bodies are checked while over the cloth, bodies the cloth is attached to not at all
  // (ClothSide.h).
  std::vector<char> modes;
  for (const collision::RigidBodySpec& b : sc.bodies)
    modes.push_back(!b.attachments.empty() ? ClothSideTracker::kSkip
                    : b.motion             ? ClothSideTracker::kOverOnly
                                           : ClothSideTracker::kAlways);
  ClothSideTracker sides(bs, rest_normal(bs.simulation()), modes);
  WorldRun r;
  r.coupled = bs.options().realtime;
  r.thickness = sc.setup.cloths[0].material.thickness;
  r.frames = frames > 0 ? frames : sc.frames;
  for (int f = 1; f <= r.frames; ++f) {
    const cloth::FrameStats s = bs.step_frame();
    r.finite = r.finite && s.finite;
    r.max_strain = std::max(r.max_strain, s.max_strain);
    r.max_pen = std::max(r.max_pen, bs.max_penetration());
    r.cloth_ms += s.total_ms;
    r.worst_ms = std::max(r.worst_ms, s.total_ms);
    std::vector<char> was(bs.num_bodies());
    for (size_t b = 0; b < bs.num_bodies(); ++b) was[b] = sides.crossed(b);
    if (sides.update() > 0)
      for (size_t b = 0; b < bs.num_bodies(); ++b)
        if (sides.crossed(b) && !was[b]) {
          const cloth::Vec3 x = bs.body_position(b), v = bs.body_velocity(b);
          std::printf("%s frame %d: %s through the cloth at (%.3f %.3f %.3f), v (%.2f %.2f %.2f)\n",
                      name.c_str(), f, (*bs.body_colliders())[b].name.c_str(), x.x(), x.y(), x.z(), v.x(),
                      v.y(), v.z());
        }
  }
  r.cloth_ms /= r.frames;
  if (std::getenv("LOOM_DIAG"))
    for (const cloth::StageProfile& p : bs.simulation().profile()) {
      std::printf("  %-28s %9.1f ms", p.name.c_str(), p.total_ms);
      for (const auto& [k, v] : p.counters) std::printf(" %s=%.0f", k.c_str(), v);
      std::printf("\n");
    }
  if (std::getenv("LOOM_DIAG")) std::printf("  cloth steps %ld over %d frames\n", bs.cloth_steps(), r.frames);
  r.cloth_steps = bs.cloth_steps();
  r.bodies_through = sides.bodies_through();
  r.round_border = sides.sides_changed_round_border();
  for (size_t b = 0; b < bs.num_bodies(); ++b) r.final_y.push_back(bs.body_position(b).y());
  std::printf(
      "%s: %d bodies through (%d side changes round the border), max strain %.4f, max penetration %.4f m "
      "(thickness %.4f), cloth %.2f ms/frame "
      "(worst %.1f)\n",
      name.c_str(), r.bodies_through, r.round_border, r.max_strain, r.max_pen, r.thickness, r.cloth_ms,
      r.worst_ms);
  return r;
}

void expect_world_invariants(const WorldRun& r) {
  EXPECT_TRUE(r.finite);
  EXPECT_EQ(r.bodies_through, 0);
  EXPECT_LE(r.max_pen, r.thickness);
  EXPECT_LE(r.max_strain, 0.10 + 1e-9);
}

// Disabled: these do not hold yet in the bridge's setup tier (BulletClothSettings::Tier::setup, kSetupTier:
// implicit Euler, the scenes' strain limit, vertex contacts; figures in bench/results/bullet_world.txt). Run
// them with --gtest_also_run_disabled_tests; LOOM_TOY_SET="path=value;..." applies scene overrides after
// kSetupTier (e.g. "quality=realtime;solver={}" runs the coupled solve). Each body whose centre meets the
// cloth is printed with the frame, its position and velocity. What fails in the coupled solve (the scenes'
// own tier, whole runs; docs/bullet.md, "Coupled solve"):
//   ToyBox33: 0 bodies through, no vertex inside a body; max strain 0.169 (limit 0.10); 4 side changes round
//     the border (the paddle coming over the cloth and leaving it);
//   ToyBox17: 0 through; max strain 0.118;
//   Trampoline: 0 through; max strain 0.077;
//   Hammock: 0 through; max strain 0.290 (edges near the hammock's middle, x = 0.06 m, the box beside them);
//   CurtainAndBalls: 0 through; the 3 balls change side by the ray test at frames 13-17 (5 changes) without
//     their centres meeting the cloth: they pass under the hem of the curtain, which swung out with them;
//     max strain 0.112;
//   FlagOnPole: 0 through; max strain 0.117.
std::vector<std::string> setup_tier(std::vector<std::string> sets = {}) {
  sets.insert(sets.begin(), kSetupTier.begin(), kSetupTier.end());
  return sets;
}

TEST(BulletWorld, DISABLED_ToyBox33NoBodyThrough) {
  expect_world_invariants(run_world("toy_box.json", setup_tier()));
}

TEST(BulletWorld, DISABLED_ToyBox17NoBodyThrough) {
  expect_world_invariants(run_world("toy_box.json", setup_tier({"cloths.0.mesh.nodes=[17,17]"})));
}

// The other Bullet-world scenes under the same invariants over their whole duration (test_bullet_scenes.cpp
// checks their strain and held bodies over the impact only).
TEST(BulletWorld, DISABLED_TrampolineNoBodyThrough) {
  expect_world_invariants(run_world("trampoline.json", setup_tier()));
}
TEST(BulletWorld, DISABLED_HammockNoBodyThrough) {
  expect_world_invariants(run_world("hammock.json", setup_tier()));
}
TEST(BulletWorld, DISABLED_CurtainAndBallsNoBodyThrough) {
  expect_world_invariants(run_world("curtain_and_balls.json", setup_tier()));
}
TEST(BulletWorld, DISABLED_FlagOnPoleNoBodyThrough) {
  expect_world_invariants(run_world("flag_on_pole.json", setup_tier()));
}

// The coupled solve (BulletClothSettings::Tier::realtime, which the scenes' "quality": "realtime" picks) on
// every Bullet-world scene, whole runs: no body's centre ever meets the cloth, no cloth vertex inside a body
// deeper than the thickness, finite. Its strain is held to what it reaches today (the 10 % bound above is not
// met yet), so a regression fails.
void expect_contact_invariants(const WorldRun& r, double max_strain) {
  EXPECT_TRUE(r.coupled);
  EXPECT_TRUE(r.finite);
  EXPECT_EQ(r.bodies_through, 0);
  EXPECT_LE(r.max_pen, r.thickness);
  EXPECT_LE(r.max_strain, max_strain);
}

WorldRun run_coupled(const std::string& name, std::vector<std::string> sets = {}) {
  return run_world(name, std::move(sets));
}

TEST(BulletWorld, CoupledToyBox33NoBodyThrough) {
  const WorldRun r = run_coupled("toy_box.json");
  expect_contact_invariants(r, 0.175);
  // The adaptive count reads the relative motion of cloth and bodies: with inelastic contacts the resting
  // bag does not jitter, so it takes about 21 cloth steps per frame (10282 over the run without them).
  EXPECT_LE(r.cloth_steps, 6000);
}
TEST(BulletWorld, CoupledToyBox17NoBodyThrough) {
  expect_contact_invariants(run_coupled("toy_box.json", {"cloths.0.mesh.nodes=[17,17]"}), 0.125);
}
TEST(BulletWorld, CoupledTrampolineNoBodyThrough) {
  // The trampoline keeps the reference tier for its rebound: the coupled tier pinned here.
  expect_contact_invariants(run_coupled("trampoline.json", {"quality=realtime", "solver={}"}), 0.115);
}
TEST(BulletWorld, CoupledHammockNoBodyThrough) {
  expect_contact_invariants(run_coupled("hammock.json"), 0.32);
}
TEST(BulletWorld, CoupledCurtainAndBallsNoBodyThrough) {
  expect_contact_invariants(run_coupled("curtain_and_balls.json"), 0.13);
}
TEST(BulletWorld, CoupledFlagOnPoleNoBodyThrough) {
  expect_contact_invariants(run_coupled("flag_on_pole.json"), 0.13);
}

}  // namespace
}  // namespace loom::test
