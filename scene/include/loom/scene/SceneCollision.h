#pragma once
// Scene key `collision`: self-collision and collision between cloths (SelfCollisionStage.h).
//   "collision": {"self": true, "thickness": 0.002, "friction": 0.3, "static_friction": 0.4, "passes": 4,
//                 "separation": 0.25, "repulsion": 0.1, "normal_cones": true, "layers": [0.002, 0.003],
//                 "friction_pairs": [{"a": "shirt", "b": "coat", "friction": 0.2, "static_friction": 0.3},
//                                    {"a": "shirt", "b": "ball", "friction": 0.6}]}
// `friction_pairs`: Coulomb coefficients per material pair; "a" names a cloth, "b" a cloth (the same one for
// self-contact) or a collider; they win over `friction`/`static_friction` and the collider's coefficients.
// `thickness` applies to every cloth (default: each cloth's material thickness); `layers` gives one
// thickness per cloth (m, in the order of `cloths`) and wins over `thickness`.
#include "loom/scene/JsonReader.h"
#include "loom/scene/Scene.h"

namespace loom::scene {

// Reads `collision` from the top-level reader when present; call after the cloths are parsed.
void parse_collision(const JsonReader& root, Scene& scene);

}  // namespace loom::scene
