#include "DetailView.h"

namespace loom::app {

DetailView::DetailView(const scene::Scene& scene, cloth::Simulation& sim) : sim_(sim) {
  if (scene.detail.empty()) return;
  shown_ = std::make_unique<std::vector<std::unique_ptr<cloth::Cloth>>>();
  const auto& cloths = sim.cloths();
  for (size_t c = 0; c < cloths.size(); ++c) {
    auto it = scene.detail.find(static_cast<int>(c));
    if (it != scene.detail.end()) {
      faces_.push_back(std::make_unique<cloth::CurvedFaces>(cloths[c]->mesh(), it->second.levels, scene.file,
                                                            "cloths[" + std::to_string(c) + "].detail"));
      faces_.back()->set_wrinkles(it->second.wrinkles, scene.file,
                                  "cloths[" + std::to_string(c) + "].detail");
      shown_->push_back(std::make_unique<cloth::Cloth>(cloths[c]->name(), faces_.back()->fine_mesh(),
                                                       cloths[c]->material()));
    } else {
      faces_.push_back(nullptr);
      shown_->push_back(
          std::make_unique<cloth::Cloth>(cloths[c]->name(), cloths[c]->mesh_ptr(), cloths[c]->material()));
    }
  }
  update();
}

void DetailView::update() {
  if (!shown_) return;
  const auto& cloths = sim_.cloths();
  for (size_t c = 0; c < cloths.size(); ++c) {
    cloth::ClothState& out = (*shown_)[c]->state();
    const cloth::ClothState& in = cloths[c]->state();
    if (faces_[c]) {
      faces_[c]->evaluate(in.x, out.x);
      out.v.assign(out.x.size(), cloth::Vec3::Zero());
    } else {
      out.x = in.x;
      out.v = in.v;
    }
    out.x_prev = out.x;
  }
}

}  // namespace loom::app
