#pragma once
// Scene key `guard`: the non-finite / explosion guard's settings (cloth/Guard.h).
//   "guard": {"enabled": true, "max_halvings": 5, "max_strain": 10, "energy_growth": 100,
//             "energy_bound": 0, "max_penetration": 0, "intersections": false}
//   (energy_bound, max_penetration: 0 = off; intersections: needs `collision` with self-collision or several
//   cloths; Guard.h)
#include "loom/cloth/Guard.h"
#include "loom/scene/JsonReader.h"

namespace loom::scene {

// Reads `guard` from the top-level reader when present (defaults otherwise).
void parse_guard(const JsonReader& root, cloth::GuardSettings& guard);

}  // namespace loom::scene
