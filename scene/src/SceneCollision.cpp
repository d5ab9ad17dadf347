// Scene key `collision` (SceneCollision.h).
#include "loom/scene/SceneCollision.h"

#include <algorithm>
#include <iterator>
#include <map>
#include <string>
#include <tuple>

#include "loom/cloth/HiddenText.h"
#include "loom/scene/SceneLimits.h"

namespace loom::scene {

void parse_collision(const JsonReader& root, Scene& scene) {
  if (!root.has("collision")) return;
  const JsonReader c = root.object("collision");
  collision::SelfCollisionSettings s;
  s.self = c.boolean("self", true);
  const int n = static_cast<int>(scene.setup.cloths.size());
  const double all = c.thickness("thickness", 0.0);  // 0: each cloth's material thickness
  s.thickness.assign(n, 0.0);
  for (int i = 0; i < n; ++i) s.thickness[i] = all > 0.0 ? all : scene.setup.cloths[i].material.thickness;
  if (c.has("layers")) {
    const std::vector<double> layers = c.numbers("layers");
    if (static_cast<int>(layers.size()) != n)
      c.fail("layers", "expected one thickness per cloth (" + std::to_string(n) + "), got " +
                           std::to_string(layers.size()));
    for (int i = 0; i < n; ++i) {
      if (!(layers[i] > 0.0) || layers[i] > kMaxContactThickness)
        c.fail("layers[" + std::to_string(i) + "]", "must be in (0, " + show_count(kMaxContactThickness) +
                                                        "] m, a contact thickness (got " +
                                                        show_count(layers[i]) + ")");
      s.thickness[i] = layers[i];
    }
  }
  for (int i = 0; i < n; ++i)
    if (!(s.thickness[i] > 0.0)) c.fail("thickness", "cloth " + std::to_string(i) + " has no thickness > 0");
  if (c.has("friction")) s.friction = c.friction("friction");
  if (c.has("static_friction")) s.static_friction = c.friction("static_friction");
  if (s.static_friction >= 0.0 && s.friction >= 0.0 && s.static_friction < s.friction)
    c.fail("static_friction", "must be >= friction");
  s.passes = c.integer("passes", s.passes, 0, 1000);
  s.separation = c.number("separation", s.separation, 0.0);
  if (s.separation >= 1.0) c.fail("separation", "must be < 1 (a fraction of the thickness)");
  s.repulsion = c.number("repulsion", s.repulsion, 0.0);
  if (s.repulsion > 1.0) c.fail("repulsion", "must be <= 1");
  s.normal_cones = c.boolean("normal_cones", s.normal_cones);
  // `method`: "exact" (SelfCollisionStage) or "proximity" (RealtimeSelfCollisionStage; `thickness` is then
  // the proximity kept between cloths, default 2 cm, half of it within one cloth; `every` its budget in
  // substeps; `padding` the broad phase's margin, default 2 cm).
  const QualityTier& tier = scene.quality;
  const std::string method =
      c.string("method", tier.realtime_self ? "proximity" : "exact", {"exact", "proximity"});
  // A Bullet world (a scene with `bodies`) runs the exact stage whatever the tier (ScenePipeline.cpp): the
  // proximity method and its keys, given there, would have no effect.
  if (!scene.bodies.empty()) {
    const std::string world =
        "is not used in a Bullet world (a scene with 'bodies'), whose self- and cloth-cloth collision is "
        "the exact stage whatever the quality";
    if (c.has("method") && method == "proximity")
      c.fail("method", "\"proximity\" " + world + "; remove it, or give \"exact\"");
    for (const char* key : {"every", "padding"})
      if (c.has(key)) c.fail(key, world + " (" + key + " is a setting of \"proximity\"); remove it");
  }
  if (method == "exact")
    for (const char* key : {"every", "padding"})
      if (c.has(key))
        c.fail(key, std::string("is not used by the exact method (collision.method \"exact\", ") +
                        (c.has("method") ? "given here" : "quality \"" + tier.name + "\"'s choice") +
                        "): " + key + " is a setting of collision.method \"proximity\"");
  if (method == "proximity") {
    collision::RealtimeSelfSettings p;
    p.self = s.self;
    p.thickness = c.thickness("thickness", p.thickness, true);
    p.every = c.integer("every", tier.self_every, 1);
    p.padding = c.number("padding", p.padding, 0.0, true);
    // A margin of motion between broad phases, not a reach: past a metre every pair of a garment would
    // be a candidate on every run.
    if (p.padding > 1.0) c.fail("padding", "must be <= 1 m (got " + show_count(p.padding) + " m)");
    scene.proximity = p;
  }
  if (c.has("friction_pairs")) {
    const std::vector<JsonReader> fps = c.objects("friction_pairs");
    // Names to indices (collider names are unique; cloth and garment names need not be), and the pairs
    // given so far as (collider, cloth, other cloth) with a cloth-cloth pair in ascending order: lookups
    // in log time.
    std::multimap<std::string, int> cloth_of;
    std::map<std::string, int> collider_of;
    for (int i = 0; i < n; ++i) cloth_of.emplace(scene.setup.cloths[i].name, i);
    for (size_t k = 0; k < scene.colliders.size(); ++k)
      collider_of[scene.colliders[k].name] = static_cast<int>(k);
    std::map<std::tuple<int, int, int>, size_t> given;
    for (const JsonReader& f : fps) {
      // Names: "a" a cloth; "b" a cloth (the same one: self-contact) or a collider. A name that stands for
      // more than one object would leave the pair's meaning to a rule the user cannot see: refused.
      auto cloth_index = [&](const char* field, const std::string& name, bool or_collider) {
        const auto [first, last] = cloth_of.equal_range(name);
        if (first == last) return -1;
        if (std::next(first) != last)
          f.fail(field, "'" + show_value(name) + "' names " + scene.cloth_field(first->second) + " and " +
                            scene.cloth_field(std::next(first)->second) +
                            ": a friction pair needs names that stand for one cloth each");
        if (or_collider && collider_of.count(name))
          f.fail(field, "'" + show_value(name) + "' names " + scene.cloth_field(first->second) +
                            " and colliders[" + std::to_string(collider_of.at(name)) +
                            "]: a friction pair needs names that stand for one object each");
        return first->second;
      };
      collision::FrictionPair fp;
      const std::string a = f.string("a"), b = f.string("b");
      fp.cloth = cloth_index("a", a, false);
      if (fp.cloth < 0) f.fail("a", "no cloth named '" + show_value(a) + "'");
      fp.other_cloth = cloth_index("b", b, true);
      if (fp.other_cloth < 0) {
        const auto it = collider_of.find(b);
        if (it != collider_of.end()) fp.collider = it->second;
        if (fp.collider < 0) f.fail("b", "no cloth or collider named '" + show_value(b) + "'");
      }
      fp.friction = f.friction("friction");
      fp.static_friction = f.friction("static_friction", fp.friction);
      if (fp.static_friction < fp.friction) f.fail("static_friction", "must be >= friction");
      f.finish();
      // One entry per pair, in either order: a second would silently win or lose.
      const bool cloths = fp.collider < 0;
      const std::tuple<int, int, int> key(fp.collider, cloths ? std::min(fp.cloth, fp.other_cloth) : fp.cloth,
                                          cloths ? std::max(fp.cloth, fp.other_cloth) : fp.other_cloth);
      const auto [at, fresh] = given.emplace(key, s.friction_pairs.size());
      if (!fresh)
        f.fail("b", "the pair '" + show_value(a) + "' / '" + show_value(b) +
                        "' is already given by friction_pairs[" + std::to_string(at->second) +
                        "]: give each pair once");
      s.friction_pairs.push_back(fp);
    }
  }
  c.finish();
  scene.collision = s;
}

}  // namespace loom::scene
