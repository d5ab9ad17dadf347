#pragma once
// The scene's top-level `colliders` array (docs/scene-format.md, docs/collision.md): rigid shapes the cloth
// collides with, with optional kinematic motion. Parsed into Scene::colliders; build_simulation puts them in
// the shared ColliderSet and adds the body_collision stage when the set is not empty.
#include "loom/scene/JsonReader.h"
#include "loom/scene/Scene.h"

namespace loom::scene {

// Reads `colliders` if present (errors name file, JSON path and problem); relative OBJ paths resolve
// against the scene file's folder.
void parse_colliders(const JsonReader& root, Scene& scene);

}  // namespace loom::scene
