// Determinism and save/restore with collisions and characters, on shipped scenes made small with
// overrides (the same path as `loom run --set`):
//   - sphere_spin (a sheet on a spinning sphere, body collision) with self-collision on, 13x13 nodes;
//   - character_cape (a cape on the CMU jump, capsule rig, tethers) at 0.08 m resolution, self-collision on;
//   - layer_stack (eleven sheets, cloth-cloth collision between layers).
// For each: the same scene and thread count gives the same FNV-1a hash of every frame's x and v; 1 and 2
// threads give the same hash; save_state after k frames loaded into a freshly built simulation continues
// bit-identically (what `loom run --resume` does; tests/apps/test_checkpoint_cli.cpp runs it end to end).
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace loom {
namespace {

struct SceneCase {
  const char* name;
  const char* file;  // under scenes/
  std::vector<std::string> overrides;
  int frames;
  bool collides =
      true;  // contacts within `frames` (the cape scene: 0 contacts counted in its first 10 frames)
};

std::vector<SceneCase> scene_cases() {
  std::vector<SceneCase> c = {
      {"sphere_spin_self",
       "sphere_spin.json",
       {"cloths[0].mesh.nodes=[13,13]", "collision={\"self\":true}"},
       16},
      {"layer_stack", "layer_stack.json", {}, 8},
  };
#ifdef LOOM_HAVE_CHARACTERS
  c.push_back({"character_cape_self",
               "character_cape_reference.json",
               {"character.garments[0].resolution=0.08", "collision={\"self\":true}"},
               10,
               false});
  // The real-time tier: proximity cloth-cloth with its candidate list, real-time body contact.
  c.push_back({"character_layers_realtime", "character_layers.json", {}, 24});
#endif
  return c;
}

void hash_bytes(std::uint64_t& h, const void* data, size_t n) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;  // FNV-1a
}

void hash_state(std::uint64_t& h, const cloth::Simulation& sim) {
  for (const auto& c : sim.cloths()) {
    hash_bytes(h, c->state().x.data(), c->state().x.size() * sizeof(cloth::Vec3));
    hash_bytes(h, c->state().v.data(), c->state().v.size() * sizeof(cloth::Vec3));
  }
}

scene::Scene load(const SceneCase& c, int threads) {
  std::vector<std::string> o = c.overrides;
  o.push_back("threads=" + std::to_string(threads));
  return scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/" + c.file, o);
}

// Hash of frames 0..frames; also checks that the scene does collide (contacts counted by a collision stage).
std::uint64_t run_hash(const SceneCase& c, int threads) {
  auto sim = scene::build_simulation(load(c, threads));
  std::uint64_t h = 1469598103934665603ull;
  hash_state(h, *sim);
  for (int f = 0; f < c.frames; ++f) {
    const cloth::FrameStats s = sim->step_frame();
    EXPECT_TRUE(s.finite) << c.name << " frame " << f + 1 << ": " << sim->failure();
    hash_state(h, *sim);
  }
  double contacts = 0.0;
  for (const auto& p : sim->profile())
    if (p.name == "body_collision" || p.name == "self_collision" || p.name == "realtime_contact" ||
        p.name == "realtime_self_collision")
      for (const auto& [k, v] : p.counters)
        if (k == "contacts") contacts += v;
  if (c.collides) {
    EXPECT_GT(contacts, 0.0) << c.name << ": the run must exercise collision";
  }
  return h;
}

class SceneDeterminism : public ::testing::TestWithParam<SceneCase> {};

TEST_P(SceneDeterminism, SameThreadsSameHash) { EXPECT_EQ(run_hash(GetParam(), 1), run_hash(GetParam(), 1)); }

TEST_P(SceneDeterminism, OneAndTwoThreadsSameHash) {
  EXPECT_EQ(run_hash(GetParam(), 1), run_hash(GetParam(), 2));
}

TEST_P(SceneDeterminism, SaveAndLoadStateContinuesBitIdentically) {
  const SceneCase& c = GetParam();
  const int k = c.frames / 2;
  auto a = scene::build_simulation(load(c, 1));
  for (int f = 0; f < k; ++f) a->step_frame();
  cloth::StateWriter saved;
  a->save_state(saved);
  std::uint64_t ha = 1469598103934665603ull;
  for (int f = k; f < c.frames; ++f) {
    a->step_frame();
    hash_state(ha, *a);
  }
  auto b =
      scene::build_simulation(load(c, 1));  // fresh: colliders, rig and contact state come from the archive
  cloth::StateReader in(saved.data(), "memory");
  b->load_state(in);
  EXPECT_EQ(b->frame(), k);
  std::uint64_t hb = 1469598103934665603ull;
  for (int f = k; f < c.frames; ++f) {
    b->step_frame();
    hash_state(hb, *b);
  }
  EXPECT_EQ(ha, hb) << c.name;
}

INSTANTIATE_TEST_SUITE_P(Scenes, SceneDeterminism, ::testing::ValuesIn(scene_cases()),
                         [](const ::testing::TestParamInfo<SceneCase>& info) {
                           return std::string(info.param.name);
                         });

}  // namespace
}  // namespace loom
