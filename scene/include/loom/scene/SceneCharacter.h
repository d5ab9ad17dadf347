#pragma once
// The scene's `character` object (docs/scene-format.md, docs/characters.md): a mocap clip, its capsule rig
// and the garments fitted to it. Garments become cloths of the scene (appended to setup.cloths, their
// attached vertices pinned); the character itself goes into Scene::character for build_simulation.
#include <string>

#include "loom/cloth/Material.h"
#include "loom/scene/JsonReader.h"
#include "loom/scene/Scene.h"

namespace loom::scene {

// Reads root["character"] when present (SceneCharacter.cpp). Relative paths resolve against the scene's
// folder.
void parse_character(const JsonReader& root, Scene& scene);

// A cloth's `material` key (preset name or object), as the `cloths` entries read it (Scene.cpp).
cloth::Material parse_material(const JsonReader& cloth_reader, const std::string& file);

}  // namespace loom::scene
