#pragma once
// The scene's top-level `bodies` array (docs/scene-format.md, docs/bullet.md): Bullet rigid bodies the cloth
// lives with, two-way coupled through the Bullet bridge (`loom compare`). Plain data (RigidBodySpec.h).
#include "loom/scene/JsonReader.h"
#include "loom/scene/Scene.h"

namespace loom::scene {

// Reads `bodies` if present into Scene::bodies; errors name the file, JSON path and problem.
void parse_bodies(const JsonReader& root, Scene& scene);

}  // namespace loom::scene
