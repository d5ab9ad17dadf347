#pragma once
// Scene key `collision` (issue 5): self-collision and collision between cloths (SelfCollisionStage.h).
//   "collision": {"self": true, "thickness": 0.002, "friction": 0.3, "static_friction": 0.4, "passes": 4,
//                 "separation": 0.25, "repulsion": 0.1, "normal_cones": true, "layers": [0.002, 0.003]}
// `thickness` applies to every cloth (default: each cloth's material thickness); `layers` gives one
// thickness per cloth (m, in the order of `cloths`) and wins over `thickness`.
#include "loom/scene/JsonReader.h"
#include "loom/scene/Scene.h"

namespace loom::scene {

// Reads `collision` from the top-level reader when present; call after the cloths are parsed.
void parse_collision(const JsonReader& root, Scene& scene);

}  // namespace loom::scene
