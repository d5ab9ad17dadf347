#pragma once
// Builds the simulation a scene describes: the cloth pipeline (Simulation) plus the stages of the effects
// the scene names and nothing else (docs/architecture.md, "only the effects a scene calls for"): body
// collision only with colliders, self-collision only when asked, a character rig only with a character. Every
// command that runs a scene (`loom run`, `loom compare`, the viewer) builds it here, so they all run the same
// thing.
#include <memory>

#include "loom/cloth/Simulation.h"
#include "loom/collision/Collider.h"
#include "loom/scene/Scene.h"

namespace loom::scene {

// `colliders` (optional): receives the collider set the simulation's stages share, whose `curr` poses are
// the colliders' poses at the current time after every step (the renderer and the viewer draw them).
std::unique_ptr<cloth::Simulation> build_simulation(const Scene& scene,
                                                    collision::ColliderSetPtr* colliders = nullptr);

}  // namespace loom::scene
