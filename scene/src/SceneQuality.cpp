// Scene key `quality` (SceneQuality.h).
#include "loom/scene/SceneQuality.h"

namespace loom::scene {

std::optional<QualityTier> quality_tier(const std::string& name) {
  QualityTier t;
  t.name = name;
  if (name == "reference") return t;
  if (name == "realtime") {
    t.method = "fast_xpbd";
    t.iterations = 1;
    t.substeps = 12;
    t.strain_limit = t.tethers = true;
    t.realtime_contact = t.realtime_self = true;
    t.self_every = 2;
    return t;
  }
  if (name == "balanced") {
    t.method = "fast_xpbd";
    t.iterations = 1;
    t.substeps = 32;
    t.strain_limit = t.tethers = true;
    t.realtime_self = true;
    t.self_every = 1;
    return t;
  }
  return std::nullopt;
}

WorldTier world_tier(const std::string& quality) {
  WorldTier w;
  w.coupled = quality == "realtime" || quality == "balanced";
  if (quality == "balanced") {
    w.substeps = 16;  // 4 cloth steps per Bullet substep at 4 Bullet substeps per frame
    w.coupling_iterations = 4;
  }
  return w;
}

QualityTier parse_quality(const JsonReader& root) {
  const std::string name = root.string("quality", "reference", {"realtime", "balanced", "reference"});
  return *quality_tier(name);
}

}  // namespace loom::scene
