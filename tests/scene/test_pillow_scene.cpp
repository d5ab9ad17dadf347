// scenes/pillow.json (PressureTerm.h): the pillow loaded from its OBJ inflates under 300 Pa and comes to rest
// on the floor, finite.
#include <gtest/gtest.h>

#include <string>

#include "loom/cloth/PressureTerm.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace loom::scene {
namespace {

// loom run measured 4.4 litres at the start and 21.0 litres from 1 s on; within 1 s the volume must at least
// triple, and the pillow must not go through the floor (y >= 0 for every vertex, the cloth's thickness is 4
// mm).
TEST(PillowScene, InflatesAndRestsOnTheFloor) {
  Scene sc = load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/pillow.json");
  auto sim = build_simulation(sc);
  const auto* term = dynamic_cast<const cloth::PressureTerm*>(sim->cloths()[0]->find_term("pressure"));
  ASSERT_NE(term, nullptr);
  const double v0 = term->volume(sim->cloths()[0]->state().x);
  bool finite = true;
  for (int f = 0; f < 60; ++f) finite = finite && sim->step_frame().finite;
  const cloth::Vec3s& x = sim->cloths()[0]->state().x;
  EXPECT_TRUE(finite);
  EXPECT_GT(term->volume(x), 3.0 * v0);
  for (const cloth::Vec3& p : x) EXPECT_GE(p.y(), 0.0);
}

}  // namespace
}  // namespace loom::scene
