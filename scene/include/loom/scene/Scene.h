#pragma once
// A scene: one JSON file naming cloths, solver, effects, duration and outputs (docs/architecture.md,
// "Scenes"). The format: docs/scene-format.md.
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "loom/cloth/CurvedFaces.h"
#include "loom/cloth/Simulation.h"
#include "loom/collision/Collider.h"
#include "loom/collision/RealtimeSelfCollision.h"
#include "loom/collision/RigidBodySpec.h"
#include "loom/collision/SelfCollisionStage.h"
#include "loom/scene/SceneQuality.h"

namespace loom::characters {
struct Character;  // loom/characters/Character.h
}

namespace loom::scene {

// output.render: settings of `loom run --render` (render/).
struct RenderOutput {
  int width = 640, height = 480;  // px
  int every = 1;                  // render every k-th frame
  bool camera = false;            // true: eye/target/fov below, else framed automatically
  cloth::Vec3 eye{0.0, 1.5, 3.0}, target{0.0, 1.0, 0.0};  // m
  double fov = 40.0;                                      // degrees, vertical
};

struct OutputSettings {
  int every = 1;       // write every k-th frame's OBJ
  bool frames = true;  // write OBJ frames at all
  // Geometry formats, each at most once: "obj" (DIR/frames/*.obj), "pc2" (DIR/pc2/<cloth>.pc2 + .obj),
  // "gltf" (DIR/animation.gltf + .bin, morph-target animation). Default: {"obj"}.
  std::vector<std::string> formats{"obj"};
  RenderOutput render;
};

struct Scene {
  std::string file;                 // path it was read from
  std::vector<std::string> inputs;  // every other file the scene read (meshes, motion clips), as opened
  double vertices = 0.0;            // cloth vertices asked for so far (SceneLimits.h, reserve_vertices)
  double collider_triangles = 0.0;  // collider mesh triangles so far (reserve_collider_triangles)
  double input_bytes = 0.0;         // bytes, what reading inputs such as a clip takes (reserve_input_bytes)
  std::string name;
  cloth::SimulationSetup setup;
  double duration = 1.0;  // s
  int frames = 60;        // frames to simulate (duration * fps, rounded)
  OutputSettings output;
  std::optional<collision::SelfCollisionSettings>
      collision;        // `collision` (SceneCollision.cpp); absent: none
  QualityTier quality;  // `quality` (SceneQuality.h): the tier the defaults below came from
  // Cloth-cloth collision by proximity (RealtimeSelfCollisionStage) instead of the exact stage: set with
  // `collision` when the tier or `collision.method: "proximity"` asks for it.
  std::optional<collision::RealtimeSelfSettings> proximity;
  bool realtime_contact = false;  // body contact by RealtimeBodyContactStage (the tier or `body_contact`)
  // The tier's strain limiting, run after body contact (then contact again, positions only) instead of
  // right after the solver: absent when the scene names `constraints.strain_limit` or the tier has none.
  std::optional<cloth::StrainLimitSettings> strain_limit_after_contact;
  std::vector<collision::RigidBodySpec> bodies;  // `bodies` (SceneBodies.cpp): Bullet rigid bodies
  WorldTier world;  // with `bodies`: how the Bullet world runs the cloths (the tier and explicit values)
  std::vector<collision::Collider>
      colliders;  // `colliders` (SceneColliders.cpp): rigid shapes, kinematic motion
  std::shared_ptr<characters::Character> character;  // `character` (SceneCharacter.cpp); null without one
  // `cloths[i].detail` (hybrid detail): cloth index -> its curved-face surface settings; the cloths
  // listed are shown (OBJ frames, exports, renders) as their refined surface instead of the simulated mesh.
  std::map<int, cloth::DetailSettings> detail;
  // The JSON path of each cloth of setup.cloths as the scene writes it: "character.garments[k]" for a
  // garment, "cloths[k]" for an entry of `cloths` (messages name the field the user wrote).
  std::vector<std::string> cloth_fields;
  // A cloth that starts inside a collider or its thickness, as regime_outliers (SceneRegime.h) words it:
  // `loom run` prints each as a warning, in every tier.
  std::vector<std::string> start_warnings;
  std::string cloth_field(int cloth) const {
    return cloth >= 0 && cloth < static_cast<int>(cloth_fields.size())
               ? cloth_fields[cloth]
               : "cloths[" + std::to_string(cloth) + "]";
  }
};

class JsonReader;
// `detail` of a cloth or of a character garment: {"method", "levels", "wrinkles"}.
cloth::DetailSettings parse_detail(const JsonReader& d);

// Reads a JSON file; syntax errors name the file, line and column.
nlohmann::json read_json_file(const std::string& path);
// Applies one `--set path=value` override (path: `solver.method`, `cloths.0.material.preset`, or
// `cloths[0].material.preset`; value: JSON if it parses, else a string).
void apply_override(nlohmann::json& root, const std::string& assignment, const std::string& file);
// Builds the simulation setup; relative mesh paths resolve against the scene's folder.
Scene parse_scene(const nlohmann::json& root, const std::string& file);
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides = {});

}  // namespace loom::scene
