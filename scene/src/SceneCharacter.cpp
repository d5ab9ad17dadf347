#include "loom/scene/SceneCharacter.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <map>
#include <sstream>
#include <vector>

#include "loom/cloth/Error.h"
#include "loom/cloth/Model.h"
#include "loom/cloth/ObjFile.h"
#include "loom/scene/JsonReader.h"
#include "loom/scene/Scene.h"
#include "loom/scene/SceneLimits.h"

#ifdef LOOM_HAVE_CHARACTERS
#include "loom/characters/Character.h"
#endif

namespace loom::scene {

namespace {

std::string resolve(const std::string& path, const std::string& scene_file) {
  std::filesystem::path p(path);
  if (p.is_relative()) p = std::filesystem::path(scene_file).parent_path() / p;
  return p.string();
}

constexpr double kMaxClipSpeed = 100.0;  // clip seconds per second
constexpr double kMaxClipStart = 1e6;    // s, the clip time at t = 0 (without loop: held past the end)

std::string show_size(double v) {  // 3 significant digits
  std::ostringstream o;
  o << std::setprecision(3) << v;
  return o.str();
}

}  // namespace

void parse_character(const JsonReader& root, Scene& scene) {
  if (!root.has("character")) return;
  const std::string& file = scene.file;
#ifndef LOOM_HAVE_CHARACTERS
  root.fail("character", "this build has no loom::characters (configure with LOOM_WITH_CHARACTERS=ON)");
#else
  namespace ch = loom::characters;
  const JsonReader c = root.object("character");
  ch::MotionSettings ms;
  std::string motion_path = resolve(c.string("bvh"), file);
  std::error_code exists_ec;
  if (std::filesystem::exists(motion_path, exists_ec))  // a missing clip: the loader's message names it
    motion_path = input_file(scene, c.child("bvh"), c.string("bvh"));
  if (c.has("scale")) {
    const nlohmann::json& s = c.raw("scale");
    if (s.is_string() && s.get<std::string>() == "auto") {
      ms.scale = 0.0;
    } else if (s.is_number() && s.get<double>() > 0.0 && s.get<double>() <= kMaxCoordinate) {
      ms.scale = s.get<double>();
    } else {
      c.fail("scale", "expected \"auto\" or metres per file unit in (0, 1000000]");
    }
  }
  ms.height = c.length("height", ms.height, true);
  ms.root_motion = c.boolean("root_motion", ms.root_motion);
  ms.loop = c.boolean("loop", ms.loop);
  ms.speed = c.number("speed", ms.speed, 0.0, true);
  if (ms.speed > kMaxClipSpeed) c.fail("speed", "must be in (0, 100] clip seconds per second");
  ms.start = c.number("start", ms.start, 0.0);
  if (ms.start > kMaxClipStart) c.fail("start", "must be in [0, 1000000] s (the clip time at t = 0)");
  // What loading the clip holds, counted against the memory before it is read.
  {
    const ch::MemoryEstimate clip = ch::estimate_clip_memory(motion_path);
    reserve_input_bytes(scene, c.child("bvh"), clip.bytes, "the clip (" + clip.basis + ") needs");
  }
  auto character = std::make_shared<ch::Character>();
  try {
    character->motion = ch::Motion::load(motion_path, ms);
  } catch (const Error& e) {
    throw Error(file, c.child("bvh"), e.what());
  }
  // A looped clip's start past its end is the same pose a whole number of cycles on, whose root motion
  // (cycles x the cycle's displacement) would cancel the placement at t = 0 only to rounding.
  if (ms.loop && ms.start > character->motion.duration())
    c.fail("start", "is past the clip's end (" + show_size(character->motion.duration()) +
                        " s): with loop, start within the clip (a later start is the same pose a cycle on)");
  // The figure's size: the diagonal of the joints' box in the clip's first pose (m). Fields that scale the
  // figure are bounded by it (a figure under 10 cm has no bones a garment could hang from); radii and
  // clearances are bounded relative to it.
  double body = 0.0;
  {
    std::vector<ch::Transform> pose;
    character->motion.clip_pose(0.0, pose);
    Eigen::AlignedBox3d box;
    for (const ch::Transform& t : pose) box.extend(t.translation());
    if (!box.isEmpty()) body = box.diagonal().norm();
  }
  constexpr double kMinFigure = 0.1;  // m
  if (!(body >= kMinFigure)) {
    const std::string field = ms.scale > 0.0 ? "scale" : c.has("height") ? "height" : "bvh";
    c.fail(field, "makes the figure " + show_size(body) + " m across its joints; at least " +
                      show_size(kMinFigure) + " m (height is in metres, scale in metres per file unit)");
  }
  // The files the clip references (a glTF's .bin buffers) are inputs of the run too (checkpoints hash them).
  for (const std::string& f : character->motion.files())
    if (std::find(scene.inputs.begin(), scene.inputs.end(), f) == scene.inputs.end())
      scene.inputs.push_back(f);
  std::map<std::string, double> radii;
  if (c.has("radii")) {
    const nlohmann::json& rj = c.raw("radii");
    if (!rj.is_object()) c.fail("radii", "expected an object {\"BoneName\": radius in m}");
    const JsonReader rr = c.object("radii");
    for (auto it = rj.begin(); it != rj.end(); ++it) {
      radii[it.key()] = rr.length(it.key());
      if (radii[it.key()] > 0.25 * body)
        rr.fail(it.key(), "must be <= 0.25 x the figure's size (" + show_size(0.25 * body) + " m)");
    }
    rr.finish();
  }
  try {
    character->rig = ch::CapsuleRig::build(character->motion, radii);
  } catch (const Error& e) {
    throw Error(file, c.child("radii"), e.what());
  }
  // Radii fitted to the motion (CapsuleRig::fit_to_motion): arm capsules kept `capsule_gap` away from the
  // torso and leg capsules over the clip; "fit_radii": false keeps the table.
  const double capsule_gap = c.length("capsule_gap", 0.02);  // m
  const bool fit_radii = c.boolean("fit_radii", true);
  if (fit_radii) character->rig.fit_to_motion(character->motion, capsule_gap);
  character->friction = c.friction("friction", character->friction);
  character->thickness = c.thickness("thickness", character->thickness);
  if (c.has("garments")) {
    const auto garments = c.objects("garments");
    if (garments.empty()) c.fail("garments", "is empty: give at least one garment, or no `garments` key");
    cloth::Vec3s layers;  // m, vertices of the garments made so far
    for (size_t k = 0; k < garments.size(); ++k) {
      const JsonReader& g = garments[k];
      ch::GarmentSpec spec;
      spec.type = g.string("type", std::nullopt, {"cape", "skirt", "shirt", "obj"});
      const std::string name = g.name("name", spec.type);
      spec.resolution = g.number("resolution", spec.resolution, 0.0, true);
      // Past a quarter of the figure a garment is its minimum grid whatever the value: refused, not clamped.
      if (spec.resolution > 0.25 * body)
        g.fail("resolution", "must be <= 0.25 x the figure's size (" + show_size(0.25 * body) + " m)");
      spec.clearance = g.length("clearance", spec.clearance);
      if (spec.clearance > 0.25 * body)
        g.fail("clearance", "must be <= 0.25 x the figure's size (" + show_size(0.25 * body) + " m)");
      // 0 takes the size from the body; a garment shorter than 1 cm would be degenerate: refused by its
      // field, not by a triangle.
      auto size = [&g](const char* key, double fallback) {
        const double v = g.number(key, fallback);
        if (g.has(key) && !(v == 0.0 || (v >= 0.01 && v <= 100.0)))
          g.fail(key, "must be 0 (from the body) or in [0.01, 100] m");
        return v;
      };
      spec.length = size("length", spec.length);
      if (spec.type == "cape") spec.width = size("width", spec.width);
      if (spec.type == "skirt") {
        spec.flare = g.number("flare", spec.flare, 0.0, true);
        if (!(spec.flare >= 0.1 && spec.flare <= 10.0))
          g.fail("flare", "must be in [0.1, 10] (hem over waist)");
      }
      if (spec.type != "obj") {
        // Vertices of a generated garment, before it is made: its area over an equilateral triangle's
        // (sqrt(3)/4 r^2) per vertex pair. A garment is fitted around the body, so its area is bounded by
        // twice the square of the body's size (the diagonal of its joints' box in the first pose; a 2.5 m x
        // 2.5 m sheet at least), or by length x width when they say more: a huge `scale` makes a huge
        // garment, refused here rather than by the allocator.
        // A skirt is a frustum from the waist (radius at most a quarter of the figure, w) to a hem `flare`
        // times as wide: lateral area pi (w + flare w) x slant, slant <= length + |flare - 1| w.
        const double waist = 0.25 * body;
        const double frustum = spec.type == "skirt"
                                   ? M_PI * waist * (1.0 + spec.flare) *
                                         (std::max(spec.length, 0.0) + std::abs(spec.flare - 1.0) * waist)
                                   : 0.0;
        const double area = std::max(
            {6.25, std::max(spec.length, 2.5) * std::max(spec.width, 2.5), 2.0 * body * body, frustum});
        reserve_vertices(scene, g.child("resolution"),
                         2.0 * area / (std::sqrt(3.0) * spec.resolution * spec.resolution));
      }
      if (spec.type == "obj") {
        spec.path = input_file(scene, g.child("path"), g.string("path"));
        // Its vertices and the memory of reading it, estimated from its lines before it is parsed.
        ObjCounts counts;
        try {
          counts = count_obj_elements(spec.path);
        } catch (const Error& e) {
          throw Error(scene.file, g.child("path"), e.what());
        }
        reserve_vertices(scene, g.child("path"), counts.vertices);
        check_obj_reading(scene, g.child("path"), counts);
        spec.scale = g.length("scale", 1.0, true);
        if (spec.scale < kMinMeshScale) g.fail("scale", "must be >= 1e-06 (a mesh too small to simulate)");
        spec.translate = g.point("translate", cloth::Vec3::Zero());
        const nlohmann::json& aj = g.raw("attach");
        if (!aj.is_object() || aj.empty())
          g.fail("attach", "expected {\"obj group\": \"bone name\" or \"nearest\", ...}");
        const JsonReader ar = g.object("attach");
        for (auto it = aj.begin(); it != aj.end(); ++it) spec.attach[it.key()] = ar.string(it.key());
        ar.finish();
        // Coordinates by their line before the mesh is built, as an OBJ cloth's are (cloths[].mesh.scale).
        const cloth::ObjFile obj = [&] {
          try {
            return cloth::read_obj_file(spec.path);
          } catch (const Error& e) {  // as make_garment names a file it cannot read
            throw Error(file, g.path(), e.what());
          }
        }();
        Eigen::AlignedBox3d box;
        for (size_t i = 0; i < obj.positions.size(); ++i) {
          const cloth::Vec3 x = spec.scale * obj.positions[i] + spec.translate;
          if (!(x.cwiseAbs().maxCoeff() <= kMaxCoordinate))
            g.fail("scale", "puts vertex " + std::to_string(i + 1) + " (line " +
                                std::to_string(obj.position_lines[i]) + " of " + g.string("path") + ") at (" +
                                show_size(x.x()) + ", " + show_size(x.y()) + ", " + show_size(x.z()) +
                                ") m with translate: coordinates must be within +-1e+06 m");
          box.extend(x);
        }
        if (!(box.diagonal().norm() >= kMinMeshSize))
          g.fail("scale", "makes the garment " + show_size(box.diagonal().norm()) + " m across; at least " +
                              show_size(kMinMeshSize) + " m");
      }
      cloth::Material material = parse_material(g, file);
      const std::string model = g.string("model", "springs", cloth::model_names());
      // Later garments are fitted outside the earlier ones (layers).
      // A garment the fields above could not make: the message names the fields it is made from.
      const ch::Garment garment = [&] {
        try {
          return ch::make_garment(spec, character->motion, character->rig, file, g.path(), layers);
        } catch (const ch::RemovedCapsule&) {
          throw;  // names the radii entry
        } catch (const Error& e) {
          // An OBJ garment is its mesh and attach table (its message names them); a generated one is made
          // from the fields named here.
          if (spec.type == "obj") throw;
          throw Error(
              std::string(e.what()) + " (the garment is made from " + g.path() +
              ".resolution, clearance, length, width, flare and the character's height, scale and radii)");
        }
      }();
      // The garment as made: within the coordinate bound and at least kMinMeshSize across, as a cloth's mesh
      // (an OBJ garment by its scale, a generated one by the fields it is made from).
      {
        Eigen::AlignedBox3d box;
        for (const cloth::Vec3& x : garment.mesh->rest_positions()) box.extend(x);
        const double across = box.isEmpty() ? 0.0 : box.diagonal().norm();
        const bool inside = !box.isEmpty() && box.min().cwiseAbs().maxCoeff() <= kMaxCoordinate &&
                            box.max().cwiseAbs().maxCoeff() <= kMaxCoordinate;
        const std::string problem = !inside ? "puts a vertex beyond +-1e+06 m"
                                            : "makes the garment " + show_size(across) +
                                                  " m across; at least " + show_size(kMinMeshSize) + " m";
        if (!inside || !(across >= kMinMeshSize)) {
          if (spec.type == "obj") g.fail("scale", problem);
          throw Error(file, g.path(),
                      problem + " (the garment is made from " + g.path() +
                          ".resolution, clearance, length, width, flare and the character's height, scale "
                          "and radii)");
        }
      }
      layers.insert(layers.end(), garment.mesh->rest_positions().begin(),
                    garment.mesh->rest_positions().end());
      if (g.has("mass"))
        material.areal_density = g.number("mass", std::nullopt, 0.0, true) / garment.mesh->total_area();
      if (g.has("detail"))  // The garment shown as its curved-face surface
        scene.detail[static_cast<int>(scene.setup.cloths.size())] = parse_detail(g.object("detail"));
      g.finish();
      character->add_garment(scene.setup, garment, name, material, model);
      scene.cloth_fields.push_back(g.path());
    }
  }
  // Arms kept clear of the attached garment vertices over the clip (an attached vertex cannot be pushed out).
  if (fit_radii) {
    std::vector<std::pair<int, cloth::Vec3> > points;
    for (const ch::Attachment& a : character->attachments) points.emplace_back(a.joint, a.local);
    character->rig.keep_clear_of(character->motion, points, 0.5 * capsule_gap);
  }
  c.finish();
  scene.character = character;
#endif
}

}  // namespace loom::scene
