#include "loom/scene/Build.h"

namespace loom::scene {

std::unique_ptr<cloth::Simulation> build_simulation(const Scene& scene) {
  auto sim = std::make_unique<cloth::Simulation>(scene.setup, scene.file);
  // Effects from other modules add their stages here, each only when the scene names it.
  return sim;
}

}  // namespace loom::scene
