#pragma once
// `loom compare` on a scene with a `character`: Loom's own run of the scene against Bullet's
// classic soft body on kinematic capsules (bullet_bridge/CharacterCompare.h). Writes DIR/compare.csv and
// DIR/compare.json with the same columns and keys as for `bodies` scenes, plus per system
// `penetrating_vertices` and `max_attachment_error` in the JSON.
#include <string>

#include "loom/bullet/CharacterCompare.h"
#include "loom/eval/OutputFolder.h"
#include "loom/scene/Scene.h"

namespace loom::app {

// The character's capsules (one kinematic body per bone, in rig order) and anchor-only bodies for
// attachment joints that start no capsule: the Bullet twin's view of the rig.
std::vector<bullet::KinematicBody> character_bodies(const std::shared_ptr<const characters::Character>& ch);

// Writes into `folder` (claimed: OutputFolder.h).
int compare_character(const scene::Scene& scene, int frames, eval::OutputFolder& folder);

}  // namespace loom::app
