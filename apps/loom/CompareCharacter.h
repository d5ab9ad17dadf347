#pragma once
// `loom compare` on a scene with a `character`: Loom's own run of the scene against Bullet's
// classic soft body on kinematic capsules (bullet_bridge/CharacterCompare.h). Writes DIR/compare.csv and
// DIR/compare.json with the same columns and keys as for `bodies` scenes, plus per system
// `penetrating_vertices` and `max_attachment_error` in the JSON.
#include <string>

#include "loom/scene/Scene.h"

namespace loom::app {

int compare_character(const scene::Scene& scene, int frames, const std::string& out);

}  // namespace loom::app
