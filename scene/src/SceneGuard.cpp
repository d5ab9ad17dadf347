#include "loom/scene/SceneGuard.h"

namespace loom::scene {

void parse_guard(const JsonReader& root, cloth::GuardSettings& g) {
  if (!root.has("guard")) return;
  const JsonReader r = root.object("guard");
  g.enabled = r.boolean("enabled", g.enabled);
  g.max_halvings = r.integer("max_halvings", g.max_halvings, 0, 20);  // up to 2^20 times the substeps
  g.max_strain = r.number("max_strain", g.max_strain, 0.0, true);
  g.energy_growth = r.number("energy_growth", g.energy_growth, 0.0, true);
  if (g.energy_growth < 1.0) r.fail("energy_growth", "must be >= 1");
  g.energy_bound = r.number("energy_bound", g.energy_bound, 0.0);
  g.max_penetration = r.number("max_penetration", g.max_penetration, 0.0);
  g.intersections_set = r.has("intersections");
  g.intersections = r.boolean("intersections", g.intersections);
  r.finish();
}

}  // namespace loom::scene
