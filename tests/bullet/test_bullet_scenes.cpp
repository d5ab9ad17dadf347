// The Bullet-world scenes (trampoline, hammock, flag_on_pole, curtain_and_balls, character_cape_crates) run
// as `loom run` runs them (BulletScene): the cloth's strain stays bounded under the heavy contacts, and the
// bodies do what the scene says.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "loom/bullet/BulletCloth.h"
#include "loom/bullet/BulletScene.h"
#include "loom/collision/ColliderDistance.h"
#include "loom/scene/Scene.h"
#include "loom/scene/ScenePipeline.h"

namespace loom::test {
namespace {

struct SceneRun {
  double max_strain = 0.0, max_pen = 0.0;
  int worst_frame = 0;
  std::vector<double> final_y;  // m, the bodies' heights at the end
};

// The bridge's setup tier (BulletClothSettings::Tier::setup) with implicit Euler at the Bullet step: the
// scenes declare the coupled tier ("quality": "realtime"; test_bullet_toy_box.cpp), these bounds are the
// setup tier's.
SceneRun run_scene(const std::string& name, int frames = -1) {
  std::vector<std::string> sets = {"quality=reference",
                                   R"(solver={"method": "implicit_euler", "dt": 0.004166666666666667})"};
  if (const char* e = std::getenv("LOOM_DIAG_SET")) sets.push_back(e);
  const scene::Scene sc = scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/" + name, sets);
  bullet::BulletScene bs(sc.setup, sc.bodies, scene::bullet_scene_options(sc));
  EXPECT_FALSE(bs.options().realtime);
  SceneRun r;
  const int n = frames > 0 ? frames : sc.frames;
  const bool diag = std::getenv("LOOM_DIAG") != nullptr;
  for (int f = 1; f <= n; ++f) {
    const cloth::FrameStats s = bs.step_frame();
    EXPECT_TRUE(s.finite) << name << " frame " << f;
    if (s.max_strain > r.max_strain) r.max_strain = s.max_strain, r.worst_frame = f;
    r.max_pen = std::max(r.max_pen, bs.max_penetration());
    if (diag) {
      const auto& c = *bs.simulation().cloths()[0];
      const auto& st = c.state();
      const auto& springs = c.mesh().springs();
      double worst = -1;
      int wi = -1, wj = -1;
      for (int k : c.mesh().strain_springs()) {
        const auto& d = springs[k];
        const double e = (st.x[d.j] - st.x[d.i]).norm() / d.rest_length - 1.0;
        if (e > worst) worst = e, wi = d.i, wj = d.j;
      }
      std::printf("%s f%d strain %.3f edge %d-%d (%.3f %.3f %.3f)-(%.3f %.3f %.3f) pen %.4f", name.c_str(), f,
                  worst, wi, wj, st.x[wi].x(), st.x[wi].y(), st.x[wi].z(), st.x[wj].x(), st.x[wj].y(),
                  st.x[wj].z(), bs.max_penetration());
      for (size_t b = 0; b < bs.num_bodies(); ++b) {
        const cloth::Vec3 p = bs.body_position(b);
        std::printf(" b%zu(%.3f %.3f %.3f)", b, p.x(), p.y(), p.z());
      }
      std::printf("\n");
    }
  }
  for (size_t b = 0; b < bs.num_bodies(); ++b) r.final_y.push_back(bs.body_position(b).y());
  std::printf("%s: max strain %.4f (frame %d), max penetration %.4f m\n", name.c_str(), r.max_strain,
              r.worst_frame, r.max_pen);
  return r;
}

// Bounds: max edge strain (stats' strain edges) with cloth-edge contacts and adaptive cloth steps, over the
// frames run here.
TEST(BulletScenes, TrampolineStrainBounded) {
  const SceneRun r = run_scene("trampoline.json", 40);  // the impact and the bounce (max at frame 15)
  EXPECT_LT(r.max_strain, 0.3);
  EXPECT_LT(r.max_pen, 1e-3);
}

TEST(BulletScenes, HammockStrainBoundedBoxHeld) {
  const SceneRun r = run_scene("hammock.json", 90);
  EXPECT_LT(r.max_strain, 0.6);
  EXPECT_LT(r.max_pen, 1e-3);
  EXPECT_GT(r.final_y.at(2), 0.85);  // the box lies in the hammock (posts' tops at 1.0), not through it
}

TEST(BulletScenes, CurtainStrainBounded) {
  const SceneRun r = run_scene("curtain_and_balls.json", 25);  // the balls hit it by frame 20 (max at 14)
  EXPECT_LT(r.max_strain, 0.3);
  EXPECT_LT(r.max_pen, 1e-3);
}

TEST(BulletScenes, FlagStrainBounded) {
  const SceneRun r = run_scene("flag_on_pole.json", 70);  // max at frame 62
  EXPECT_LT(r.max_strain, 0.3);
}

// A caped mocap character in a Bullet world (ScenePipeline: the garments in the BulletCloth, the character's
// stage and capsule contact added): the whole 6 s run stays finite, no cape vertex ends a frame inside a
// crate or a capsule deeper than 1 mm, and the cape pushes the light top crates of the second stacks.
TEST(BulletScenes, CapedCharacterBrushesCrates) {
  scene::Scene sc = scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/character_cape_crates.json");
  const int frames = sc.frames;
  auto p = scene::build_pipeline(std::move(sc));
  ASSERT_NE(p->bullet(), nullptr);
  const size_t bodies = p->bullet()->num_bodies();
  ASSERT_GT(p->colliders()->size(), bodies);  // the capsules are drawn after the bodies
  std::vector<cloth::Vec3> start;
  for (size_t b = 0; b < bodies; ++b) start.push_back(p->bullet()->body_position(b));
  double deepest = 0.0;
  for (int f = 1; f <= frames; ++f) {
    ASSERT_TRUE(p->step_frame().finite) << "frame " << f;
    for (const collision::Collider& c : *p->colliders())
      for (const auto& cl : p->simulation().cloths())
        for (const cloth::Vec3& x : cl->state().x)
          deepest = std::max(deepest, -collision::signed_distance(c, c.curr, x, nullptr));
  }
  double pushed = 0.0;  // m, farthest a top crate moved
  for (size_t b = 0; b < bodies; ++b) {
    const double moved = (p->bullet()->body_position(b) - start[b]).norm();
    if (p->scene().bodies[b].mass > 0.0) pushed = std::max(pushed, moved);
    if (p->scene().bodies[b].mass == 0.0) {
      EXPECT_EQ(moved, 0.0) << p->scene().bodies[b].name;
    }
  }
  std::printf("character_cape_crates: deepest %.5f m, top crate pushed %.4f m\n", deepest, pushed);
  EXPECT_LT(deepest, 1e-3);
  EXPECT_GT(pushed, 0.005);
}

}  // namespace
}  // namespace loom::test
