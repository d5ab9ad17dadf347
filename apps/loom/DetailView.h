#pragma once
// Hybrid detail in outputs: the cloths a run writes (OBJ frames, pc2/glTF exports, --render). A
// cloth with `detail` in its scene is shown as its curved-face surface (loom/cloth/CurvedFaces.h), rebuilt
// from the simulated coarse positions after every frame; the others as simulated. Without any detail the
// simulation's own cloths are shown, nothing is copied.
#include <memory>
#include <vector>

#include "loom/cloth/Cloth.h"
#include "loom/cloth/CurvedFaces.h"
#include "loom/cloth/Simulation.h"
#include "loom/scene/Scene.h"

namespace loom::app {

class DetailView {
 public:
  DetailView(const scene::Scene& scene, cloth::Simulation& sim);
  // What outputs see.
  std::vector<std::unique_ptr<cloth::Cloth>>& cloths() { return shown_ ? *shown_ : sim_.cloths(); }
  // Rebuilds the shown surfaces from the simulation's current positions.
  void update();

 private:
  cloth::Simulation& sim_;
  std::vector<std::unique_ptr<cloth::CurvedFaces>> faces_;             // per cloth; null without detail
  std::unique_ptr<std::vector<std::unique_ptr<cloth::Cloth>>> shown_;  // null without any detail
};

}  // namespace loom::app
