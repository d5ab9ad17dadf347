#include "loom/scene/Scene.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <unordered_map>
#include <vector>

#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/Model.h"
#include "loom/cloth/ObjFile.h"
#include "loom/cloth/Solver.h"
#include "loom/scene/JsonReader.h"
#include "loom/scene/SceneBodies.h"
#include "loom/scene/SceneCharacter.h"
#include "loom/scene/SceneColliders.h"
#include "loom/scene/SceneCollision.h"
#include "loom/scene/SceneGuard.h"
#include "loom/scene/SceneLimits.h"
#include "loom/scene/SceneRegime.h"

namespace loom::scene {

using cloth::Vec3;

namespace {
std::string show(double v) { return show_number(v, 9); }  // 9 digits, more when v needs them (JsonReader.h)
}  // namespace

// Shared with SceneCharacter.cpp (garment materials).
cloth::Material parse_material(const JsonReader& cloth_reader, const std::string& file) {
  if (!cloth_reader.has("material")) return cloth::material_preset("cotton");
  const nlohmann::json& raw = cloth_reader.raw("material");
  const std::string where = cloth_reader.child("material");
  auto preset = [&](const std::string& name, const std::string& at) {
    try {
      return cloth::material_preset(name);
    } catch (const Error& e) {
      throw Error(file, at, e.what());
    }
  };
  if (raw.is_string()) return preset(raw.get<std::string>(), where);
  const JsonReader r = cloth_reader.object("material");
  if (r.has("preset") && r.has("clo")) r.fail("", "give either 'preset' or 'clo', not both");
  cloth::Material m = r.has("preset") ? preset(r.string("preset"), r.child("preset")) : cloth::Material();
  if (!r.has("preset")) m.name = "custom";
  if (r.has("clo")) {
    // Clo3D-style parameters in physical units (Material.h, CloStyleParameters).
    const JsonReader c = r.object("clo");
    cloth::CloStyleParameters p;
    p.weight = c.number("weight", p.weight, 0.0, true);
    p.thickness = c.number("thickness", p.thickness, 0.0);  // mm
    if (p.thickness > 1000.0 * kMaxContactThickness)
      c.fail("thickness",
             "must be <= " + show(1000.0 * kMaxContactThickness) + " mm (got " + show(p.thickness) + ")");
    p.stretch_weft = c.number("stretch_weft", p.stretch_weft, 0.0, true);
    p.stretch_warp = c.number("stretch_warp", p.stretch_warp, 0.0, true);
    p.shear = c.number("shear", p.shear, 0.0);
    p.bending_weft = c.number("bending_weft", p.bending_weft, 0.0);
    p.bending_warp = c.number("bending_warp", p.bending_warp, 0.0);
    p.friction = c.friction("friction", p.friction);
    p.internal_damping = c.number("internal_damping", p.internal_damping, 0.0);
    c.finish();
    m = cloth::from_clo_style(p);
  }
  // A value that must be positive (> 0) or non-negative (>= 0).
  // At most kMaxCoefficient in its own unit: a stiffness or damping of 1e300 would overflow the forces.
  auto bounded = [&](const char* key, std::optional<double> field, bool strict) {
    const double v = r.number(key, field, 0.0, strict);
    if (v > kMaxCoefficient) r.fail(key, "must be <= " + show(kMaxCoefficient) + " (got " + show(v) + ")");
    return v;
  };
  auto positive = [&](const char* key, double& field) { field = bounded(key, field, true); };
  auto non_negative = [&](const char* key, double& field) { field = bounded(key, field, false); };
  if (r.has("stretch")) m.stretch_weft = m.stretch_warp = bounded("stretch", std::nullopt, true);
  positive("stretch_weft", m.stretch_weft);
  positive("stretch_warp", m.stretch_warp);
  non_negative("shear", m.shear);
  if (r.has("bend")) m.bend_weft = m.bend_warp = bounded("bend", std::nullopt, false);
  non_negative("bend_weft", m.bend_weft);
  non_negative("bend_warp", m.bend_warp);
  positive("areal_density", m.areal_density);
  non_negative("damping", m.damping);
  m.friction = r.friction("friction", m.friction);
  m.thickness = r.thickness("thickness", m.thickness);
  r.finish();
  return m;
}

namespace {

std::shared_ptr<const cloth::ClothMesh> parse_mesh(const JsonReader& r, Scene& scene) {
  const std::string& file = scene.file;
  const std::string type = r.string("type", std::nullopt, {"grid", "obj"});
  // Mesh construction errors name the mesh (or OBJ file and line); the scene path goes in front.
  auto build = [&](auto&& make) {
    try {
      return make();
    } catch (const Error& e) {
      throw Error(file, r.path(), e.what());
    }
  };
  {
    if (type == "grid") {
      cloth::GridSpec g;
      const auto size = r.numbers("size", 2);
      for (int k = 0; k < 2; ++k)
        if (!(size[k] >= kMinMeshSize) || size[k] > kMaxCoordinate)
          r.fail("size", "both sizes must be in [" + show(kMinMeshSize) + ", " +
                             std::to_string(static_cast<long>(kMaxCoordinate)) + "] m (got " + show(size[k]) +
                             ")");
      g.size_u = size[0];
      g.size_v = size[1];
      const nlohmann::json& nodes = r.raw("nodes");
      if (!nodes.is_array() || nodes.size() != 2 || !nodes[0].is_number_integer() ||
          !nodes[1].is_number_integer())
        r.fail("nodes", "expected two integers [nodes_u, nodes_v]");
      // Checked as 64-bit values before narrowing: 2^32 + 5 is out of range, not 5.
      for (int k = 0; k < 2; ++k)
        if (!JsonReader::in_range(nodes[k], 2, 4096))
          r.fail("nodes", "each count must be in [2, 4096] (got " + nodes[k].dump() + ")");
      g.nodes_u = nodes[0].get<int>();
      g.nodes_v = nodes[1].get<int>();
      reserve_vertices(scene, r.path(), static_cast<double>(g.nodes_u) * g.nodes_v);
      const std::string plane = r.string("plane", "xz", {"xy", "xz", "yz"});
      g.plane = plane == "xy"   ? cloth::GridPlane::kXY
                : plane == "yz" ? cloth::GridPlane::kYZ
                                : cloth::GridPlane::kXZ;
      g.origin = r.vec3("origin", Vec3::Zero());
      if (!(g.origin.cwiseAbs().maxCoeff() <= kMaxCoordinate))
        r.fail("origin",
               "coordinates must be within +-" + std::to_string(static_cast<long>(kMaxCoordinate)) + " m");
      r.finish();
      auto mesh = build([&] { return cloth::ClothMesh::grid(g); });
      // The origin and the size are each within the bound; the far corner must be too.
      for (const Vec3& x : mesh->rest_positions())
        if (!(x.cwiseAbs().maxCoeff() <= kMaxCoordinate))
          r.fail("origin", "with size [" + show(g.size_u) + ", " + show(g.size_v) +
                               "] the grid reaches beyond +-" +
                               std::to_string(static_cast<long>(kMaxCoordinate)) + " m (a corner at (" +
                               show(x.x()) + ", " + show(x.y()) + ", " + show(x.z()) + "))");
      return mesh;
    }
    const std::string path = r.string("path");
    const double scale = r.number("scale", 1.0, 0.0, true);
    const Vec3 translate = r.vec3("translate", Vec3::Zero());
    if (scale > kMaxCoordinate || scale < kMinMeshScale)
      r.fail("scale", "must be in [" + show(kMinMeshScale) + ", " +
                          std::to_string(static_cast<long>(kMaxCoordinate)) + "] (got " + show(scale) + ")");
    if (!(translate.cwiseAbs().maxCoeff() <= kMaxCoordinate))
      r.fail("translate",
             "coordinates must be within +-" + std::to_string(static_cast<long>(kMaxCoordinate)) + " m");
    r.finish();
    std::filesystem::path p(path);
    if (p.is_relative()) p = std::filesystem::path(file).parent_path() / p;
    std::error_code ec;
    if (!std::filesystem::exists(p, ec))  // the OBJ loader's own message names the file
      return build([&] { return cloth::ClothMesh::from_obj(p.string(), scale, translate); });
    input_file(scene, r.child("path"),
               path);  // as written: input_file resolves it against the scene's folder
    // Its memory is estimated from its `v` lines before it is parsed (the parser's own copies would
    // otherwise be the first thing a huge file exhausts).
    const ObjCounts counts = build([&] { return count_obj_elements(p.string()); });
    reserve_vertices(scene, r.path(), counts.vertices);
    check_obj_reading(scene, r.child("path"), counts);
    // Coordinates first, by their line: a vertex past the bound (1e308) would otherwise be blamed on a
    // triangle's area.
    build([&] {
      const cloth::ObjFile obj = cloth::read_obj_file(p.string());
      for (size_t i = 0; i < obj.positions.size(); ++i) {
        const Vec3 x = scale * obj.positions[i] + translate;
        if (!(x.cwiseAbs().maxCoeff() <= kMaxCoordinate))
          throw Error(p.string(), "line " + std::to_string(obj.position_lines[i]),
                      "vertex " + std::to_string(i + 1) + " lies at (" + show(x.x()) + ", " + show(x.y()) +
                          ", " + show(x.z()) + ") m after " + r.child("scale") + " and " +
                          r.child("translate") + ": coordinates must be within +-" +
                          std::to_string(static_cast<long>(kMaxCoordinate)) + " m");
      }
      return 0;
    });
    auto mesh = build([&] { return cloth::ClothMesh::from_obj(p.string(), scale, translate); });
    for (const Vec3& x : mesh->rest_positions())
      if (!(x.cwiseAbs().maxCoeff() <= kMaxCoordinate))
        r.fail("scale", "puts a vertex beyond +-" + std::to_string(static_cast<long>(kMaxCoordinate)) + " m");
    // A mesh too small to simulate is the scale's (or the file's) doing, never the mass's.
    Eigen::AlignedBox3d box;
    for (const Vec3& x : mesh->rest_positions()) box.extend(x);
    if (!(box.diagonal().norm() >= kMinMeshSize))
      r.fail("scale", "makes the mesh " + show(box.diagonal().norm()) + " m across; at least " +
                          show(kMinMeshSize) + " m");
    return mesh;
  }
}

namespace {
// A hash of a JSON value consistent with nlohmann's operator== (numbers of any type compare by value, so they
// are hashed as doubles, +0 and -0 alike): equal values hash alike, so only a bucket's values are compared.
std::size_t json_hash(const nlohmann::json& v) {
  auto mix = [](std::size_t h, std::size_t x) {
    return h ^ (x + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2));
  };
  std::size_t h = std::hash<int>()(v.is_number() ? -1 : static_cast<int>(v.type()));
  if (v.is_number()) {
    const double d = v.get<double>();
    h = mix(h, std::hash<double>()(d == 0.0 ? 0.0 : d));
  } else if (v.is_string()) {
    h = mix(h, std::hash<std::string>()(v.get_ref<const std::string&>()));
  } else if (v.is_boolean()) {
    h = mix(h, v.get<bool>() ? 1 : 2);
  } else if (v.is_object()) {
    for (auto it = v.begin(); it != v.end(); ++it)
      h = mix(mix(h, std::hash<std::string>()(it.key())), json_hash(it.value()));
  } else if (v.is_array()) {
    for (const nlohmann::json& e : v) h = mix(h, json_hash(e));
  }
  return h;
}

// A moving pin's path: its speed on every segment, and the change of its velocity at every key, at most
// `max_speed` m/s (before the first key and after the last the pin rests: those changes are the speeds).
void check_pin_path_speed(const JsonReader& path, const cloth::PinSpec& spec, double max_speed,
                          const std::string& why) {
  auto speed = [](double v) { return v < kMaxShownCount ? show(v) : show_count(v); };
  Vec3 before = Vec3::Zero();  // m/s, the velocity on the segment ending at key k
  for (size_t k = 0; k + 1 < spec.times.size(); ++k) {
    const Vec3 v = (spec.offsets[k + 1] - spec.offsets[k]) / (spec.times[k + 1] - spec.times[k]);
    if (!(v.norm() <= max_speed))
      path.fail("offsets", "moves the pin at " + speed(v.norm()) + " m/s from entry " + std::to_string(k) +
                               " to " + std::to_string(k + 1) + "; at most " + show(max_speed) + " m/s " +
                               why);
    if (!((v - before).norm() <= max_speed))
      path.fail("offsets", "changes the pin's velocity by " + speed((v - before).norm()) + " m/s at entry " +
                               std::to_string(k) + "; at most " + show(max_speed) + " m/s " + why);
    before = v;
  }
}
}  // namespace

// The cloth's pins; `fields` gets the JSON path of the entry each came from.
std::vector<cloth::PinSpec> parse_pins(const JsonReader& r, const cloth::ClothMesh& mesh, double max_speed,
                                       const std::string& why, std::vector<std::string>& fields) {
  std::vector<cloth::PinSpec> pins;
  if (!r.has("pins")) return pins;
  // One pin per vertex. The same entry given twice is refused, and so is a vertex that two entries reach
  // with different anchors or paths (they would fight); entries that reach it the same way (two grid nodes
  // that coincide on a grid made smaller with --set, two grid_edge sides at their corner) pin it once.
  std::map<int, size_t> held;    // vertex -> index in `pins`
  std::vector<size_t> entry_of;  // pins[k] came from entries[entry_of[k]]
  const nlohmann::json& raw = r.raw("pins");
  const std::vector<JsonReader> entries = r.objects("pins");
  std::unordered_map<std::size_t, std::vector<size_t>> seen;  // json_hash -> entries, ascending
  for (size_t entry = 0; entry < entries.size(); ++entry) {
    const JsonReader& p = entries[entry];
    std::vector<size_t>& bucket = seen[json_hash(raw[entry])];
    for (size_t k : bucket)
      if (raw[k] == raw[entry])
        p.fail("", "the same pin as " + r.child("pins") + "[" + std::to_string(k) +
                       "] (given twice): its vertex is already pinned by " + r.child("pins") + "[" +
                       std::to_string(k) + "]");
    bucket.push_back(entry);
    auto hold = [&](const cloth::PinSpec& s) {  // false: the vertex is already pinned the same way
      const auto it = held.find(s.vertex);
      if (it == held.end()) {
        held[s.vertex] = pins.size();
        entry_of.push_back(entry);
        pins.push_back(s);
        return true;
      }
      const cloth::PinSpec& o = pins[it->second];
      const bool same = o.anchor.has_value() == s.anchor.has_value() &&
                        (!s.anchor || *o.anchor == *s.anchor) && o.times == s.times && o.offsets == s.offsets;
      if (!same)
        p.fail("", "pins vertex " + std::to_string(s.vertex) + ", already pinned by " + r.child("pins") +
                       "[" + std::to_string(entry_of[it->second]) + "] with another anchor or path");
      return false;
    };
    cloth::PinSpec spec;
    if (static_cast<int>(p.has("vertex")) + p.has("grid") + p.has("grid_edge") != 1)
      p.fail("", "give exactly one of 'vertex', 'grid' or 'grid_edge'");
    if (p.has("grid_edge")) {
      // A whole side of a grid: u0 (iu = 0), u1 (iu = last), v0 (iv = 0), v1 (iv = last).
      if (!mesh.is_grid()) p.fail("grid_edge", "grid pins need a grid mesh");
      const std::string side = p.string("grid_edge", std::nullopt, {"u0", "u1", "v0", "v1"});
      p.finish();
      const int nu = mesh.grid_nodes_u(), nv = mesh.grid_nodes_v();
      const bool along_v = side[0] == 'u';
      const int fixed = side[1] == '0' ? 0 : (along_v ? nu : nv) - 1;
      for (int k = 0; k < (along_v ? nv : nu); ++k) {
        cloth::PinSpec e;
        e.vertex = along_v ? mesh.grid_index(fixed, k) : mesh.grid_index(k, fixed);
        hold(e);
      }
      continue;
    }
    if (p.has("vertex")) {
      const nlohmann::json& v = p.raw("vertex");
      if (!v.is_number_integer()) p.integer("vertex");           // the type error
      if (!JsonReader::in_range(v, 0, mesh.num_vertices() - 1))  // compared before narrowing
        p.fail("vertex",
               "vertex " + v.dump() + " is out of range [0, " + std::to_string(mesh.num_vertices()) + ")");
      spec.vertex = v.get<int>();
    } else {
      if (!mesh.is_grid()) p.fail("grid", "grid pins need a grid mesh");
      const nlohmann::json& g = p.raw("grid");
      if (!g.is_array() || g.size() != 2 || !g[0].is_number_integer() || !g[1].is_number_integer())
        p.fail("grid", "expected [iu, iv] (negative counts from the far side)");
      const int nu = mesh.grid_nodes_u(), nv = mesh.grid_nodes_v();
      if (!JsonReader::in_range(g[0], -nu, nu - 1) || !JsonReader::in_range(g[1], -nv, nv - 1))
        p.fail("grid", "node is outside the " + std::to_string(nu) + "x" + std::to_string(nv) + " grid");
      int iu = g[0].get<int>(), iv = g[1].get<int>();
      if (iu < 0) iu += mesh.grid_nodes_u();
      if (iv < 0) iv += mesh.grid_nodes_v();
      if (iu < 0 || iu >= mesh.grid_nodes_u() || iv < 0 || iv >= mesh.grid_nodes_v())
        p.fail("grid", "node is outside the " + std::to_string(mesh.grid_nodes_u()) + "x" +
                           std::to_string(mesh.grid_nodes_v()) + " grid");
      spec.vertex = mesh.grid_index(iu, iv);
    }
    if (p.has("anchor")) {
      spec.anchor = p.vec3("anchor");
      if (!(spec.anchor->cwiseAbs().maxCoeff() <= kMaxCoordinate))
        p.fail("anchor",
               "coordinates must be within +-" + std::to_string(static_cast<long>(kMaxCoordinate)) + " m");
    }
    if (p.has("path")) {
      const JsonReader path = p.object("path");
      spec.times = path.numbers("times");
      const nlohmann::json& offsets = path.raw("offsets");
      if (!offsets.is_array() || offsets.size() != spec.times.size())
        path.fail("offsets", "expected one [x, y, z] offset per time");
      for (size_t k = 0; k < offsets.size(); ++k) {
        const auto& o = offsets[k];
        if (!o.is_array() || o.size() != 3 || !o[0].is_number() || !o[1].is_number() || !o[2].is_number())
          path.fail("offsets", "entry " + std::to_string(k) + " must be [x, y, z]");
        Vec3 v(o[0].get<double>(), o[1].get<double>(), o[2].get<double>());
        if (!(v.cwiseAbs().maxCoeff() <= kMaxCoordinate))
          path.fail("offsets", "entry " + std::to_string(k) + " must be finite and within +-" +
                                   std::to_string(static_cast<long>(kMaxCoordinate)) + " m");
        spec.offsets.push_back(v);
      }
      for (size_t k = 1; k < spec.times.size(); ++k)
        if (!(spec.times[k] > spec.times[k - 1])) path.fail("times", "must increase strictly");
      check_pin_path_speed(path, spec, max_speed, why);
      path.finish();
    }
    p.finish();
    hold(spec);
  }
  for (size_t k = 0; k < pins.size(); ++k)
    fields.push_back(r.child("pins") + "[" + std::to_string(entry_of[k]) + "]");
  return pins;
}

}  // namespace

cloth::DetailSettings parse_detail(const JsonReader& d) {
  cloth::DetailSettings ds;
  ds.method = d.string("method", "curved_faces", {"curved_faces"});
  ds.levels = d.integer("levels", 2, 0, 5);  // each level multiplies the triangles by 4
  if (d.has("wrinkles")) {                   // geometric wrinkles from the coarse compression (CurvedFaces.h)
    const JsonReader w = d.object("wrinkles");
    ds.wrinkles.enabled = true;
    ds.wrinkles.amplitude = w.number("amplitude", ds.wrinkles.amplitude, 0.0);
    ds.wrinkles.wavelength = w.number("wavelength", ds.wrinkles.wavelength, 0.0, true);
    // Below 0.1 mm the phase 2 pi x / wavelength overflows for scene-sized coordinates (a denormal
    // wavelength gives inf, then NaN positions); above 1 m a "wrinkle" is the garment's own shape.
    if (ds.wrinkles.wavelength < 1e-4 || ds.wrinkles.wavelength > 1.0)
      w.fail("wavelength", "must be in [0.0001, 1] m");
    if (ds.wrinkles.amplitude > 1.0) w.fail("amplitude", "must be <= 1 m");
    w.finish();
  }
  d.finish();
  return ds;
}

namespace {

// The scene's name, clock (duration, fps, frames), gravity, threads and guard.
void parse_header(const JsonReader& r, Scene& scene, const std::string& file) {
  scene.file = file;
  scene.name = r.string("name", std::filesystem::path(file).stem().string());
  // The name is the default output folder out/<name>: a plain file name, never a path.
  if (scene.name.empty() || scene.name == "." || scene.name == ".." || scene.name.size() > 200 ||
      scene.name.find_first_of("/\\") != std::string::npos)
    r.fail("name",
           "must be a plain file name of 1 to 200 characters without '/' or '\\' and not '.' or '..' "
           "(it names the default output folder out/<name>; got '" +
               show_value(scene.name) + "')");
  // A name taken from the file name is checked as scene text is (JsonReader::string): no control,
  // bidirectional or zero-width character reaches a folder name or a terminal.
  if (!r.has("name"))
    if (const HiddenChar h = find_hidden_char(scene.name); h.length)
      r.fail("name", "is not given, and the scene's file name holds a control character (" +
                         show_code(h.code) + " at byte " + std::to_string(h.byte) +
                         "): give a \"name\" or rename the file");
  if (r.has("description")) r.string("description");
  scene.duration = r.number("duration", 1.0, 0.0, true);
  const double fps = r.number("fps", 60.0, 0.0, true);
  if (fps > 100000.0 || fps < 1e-6) r.fail("fps", "must be in [1e-06, 100000] Hz (got " + show(fps) + ")");
  scene.setup.frame_dt = 1.0 / fps;
  // Checked in double before the conversion to int (a huge duration would overflow it).
  if (scene.duration * fps > static_cast<double>(kMaxFrames))
    r.fail(r.has("duration") ? "duration" : "fps", "gives " + show_count(scene.duration * fps) +
                                                       " frames (duration x fps); at most " +
                                                       std::to_string(kMaxFrames));
  // At least one whole frame (to rounding): a shorter duration (5e-324 s) would run a frame it never asked
  // for.
  if (scene.duration * fps < 1.0 - 1e-6)
    r.fail(r.has("duration") ? "duration" : "fps",
           "gives " + show(scene.duration * fps) +
               " frames (duration x fps): the run must last at least one " +
               "frame (duration >= 1/fps = " + show(scene.setup.frame_dt) + " s)");
  scene.frames = std::max(1, static_cast<int>(std::lround(scene.duration * fps)));
  scene.setup.gravity = r.vec3("gravity", Vec3(0.0, -9.81, 0.0));
  if (!(scene.setup.gravity.cwiseAbs().maxCoeff() <= kMaxAcceleration))
    r.fail("gravity", "components must be within +-" + show(kMaxAcceleration) + " m/s^2");
  scene.setup.threads = r.integer("threads", 1, 1, static_cast<int>(kMaxThreads));
  parse_guard(r, scene.setup.guard);  // non-finite / explosion guard (SceneGuard.cpp)
}

// The quality tier (SceneQuality.h) and the solver: the tier gives the defaults an explicit `solver`
// replaces.
void parse_solver(const JsonReader& r, const nlohmann::json& root, Scene& scene, const std::string& file) {
  scene.quality = parse_quality(r);
  const QualityTier& tier = scene.quality;
  scene.setup.substeps = 1;  // a scene's default (docs/scene-format.md); the tier or `solver` may change it
  const std::string default_method = tier.method.empty() ? "symplectic_euler" : tier.method;
  // The tier's substeps and iterations go with its solver only.
  auto tier_solver = [&](const std::string& method, bool substeps_given, bool iterations_given) {
    if (method != tier.method) return;
    if (!substeps_given && tier.substeps > 0) scene.setup.substeps = tier.substeps;
    if (!iterations_given && tier.iterations > 0) scene.setup.solver.params["iterations"] = tier.iterations;
  };
  if (!r.has("solver")) {
    scene.setup.solver.method = default_method;
    tier_solver(default_method, false, false);
  }
  if (r.has("solver")) {
    const JsonReader s = r.object("solver");
    const nlohmann::json& s_json = root.at("solver");
    scene.setup.solver.method = s.string("method", default_method);
    if (s.has("substeps") && s.has("dt")) s.fail("", "give either 'substeps' or 'dt', not both");
    if (s.has("dt")) {
      const double dt = s.number("dt", std::nullopt, 0.0, true);
      if (dt > scene.setup.frame_dt * (1.0 + 1e-12)) s.fail("dt", "must not exceed the frame time 1/fps");
      if (scene.setup.frame_dt / dt > static_cast<double>(kMaxSubsteps))
        s.fail("dt", "gives " + show_count(scene.setup.frame_dt / dt) +
                         " steps per frame (1/fps / dt); at most " + std::to_string(kMaxSubsteps));
      scene.setup.substeps = static_cast<int>(std::ceil(scene.setup.frame_dt / dt - 1e-9));
    } else {
      scene.setup.substeps = s.integer("substeps", 1, 1, static_cast<int>(kMaxSubsteps));
    }
    // Every other key is a solver-specific parameter; the solver checks names and ranges.
    for (auto it = s_json.begin(); it != s_json.end(); ++it) {
      const std::string& key = it.key();
      if (key == "method" || key == "substeps" || key == "dt") continue;
      if (it.value().is_boolean()) {
        scene.setup.solver.params[key] = s.boolean(key) ? 1.0 : 0.0;
      } else {
        scene.setup.solver.params[key] = s.number(key);
      }
    }
    tier_solver(scene.setup.solver.method, s.has("substeps") || s.has("dt"), s.has("iterations"));
    if (scene.setup.substeps > 1000000) s.fail("substeps", "must be <= 1000000");
    s.finish();
  }
  cloth::make_solver(scene.setup.solver, file);  // an unknown method fails here, naming solver.method
}

constexpr double kDegree = 3.141592653589793 / 180.0;  // rad

// `effects.wind`: drag and lift of a gusting wind (AeroTerm.h). Angles in degrees. The non-negative fields
// are read with their minimum 0, so a value below kMinPositive (a subnormal) is refused by the reader.
cloth::WindSettings parse_wind(const JsonReader& w) {
  cloth::WindSettings ws;
  ws.velocity = w.vec3("velocity");
  ws.density = w.number("density", ws.density, 0.0);
  ws.drag = w.number("drag", ws.drag, 0.0);
  ws.lift = w.number("lift", ws.lift, 0.0);
  if (w.has("gusts"))
    for (const JsonReader& g : w.objects("gusts")) {
      cloth::Gust gust;
      gust.amplitude = g.number("amplitude", std::nullopt, 0.0);
      gust.frequency = g.number("frequency", std::nullopt, 0.0);
      gust.phase = g.number("phase", 0.0);  // degrees, bounded as written, then in radians
      if (!(std::abs(gust.phase) <= 1e6))
        g.fail("phase", "must be in [-1000000, 1000000] degrees (got " + show(gust.phase) + ")");
      gust.phase *= kDegree;
      g.finish();
      ws.gusts.push_back(gust);
    }
  if (w.has("swing")) {
    const JsonReader sw = w.object("swing");
    const double angle = sw.number("angle", std::nullopt, 0.0);
    if (!(angle <= 180.0)) sw.fail("angle", "must be in [0, 180] degrees (got " + show(angle) + ")");
    ws.swing_angle = angle * kDegree;
    ws.swing_frequency = sw.number("frequency", std::nullopt, 0.0);
    ws.swing_axis = sw.vec3("axis", ws.swing_axis);
    sw.finish();
  }
  w.finish();
  // Ranges (AeroTerm.h); errors name the JSON path of the field.
  ws.validate(w.file(), w.path());
  return ws;
}

// `effects`: air drag and wind (AirDragTerm.h), wind with lift (AeroTerm.h); absent = no such term at all.
void parse_effects(const JsonReader& r, Scene& scene) {
  if (r.has("effects")) {
    const JsonReader e = r.object("effects");
    if (e.has("drag")) {
      const JsonReader d = e.object("drag");
      cloth::DragSettings ds;
      // Each bounded by name, so a coefficient or wind that would overflow the forces is refused here,
      // never left to stop the run as a non-finite state.
      auto bounded = [&](const char* key, double max, const char* unit) {
        const double v = d.number(key, 0.0, 0.0);
        if (v > max) d.fail(key, "must be <= " + show(max) + " " + unit + " (got " + show(v) + ")");
        return v;
      };
      ds.isotropic = bounded("isotropic", kMaxCoefficient, "(drag coefficient)");
      ds.normal = bounded("normal", kMaxCoefficient, "(drag coefficient)");
      ds.wind = d.vec3("wind", Vec3::Zero());
      if (!(ds.wind.cwiseAbs().maxCoeff() <= kMaxSpeed))
        d.fail("wind", "components must be within +-" + show(kMaxSpeed) + " m/s");
      ds.gust_amplitude = bounded("gust_amplitude", kMaxCoefficient, "(fraction of the wind)");
      ds.gust_frequency = bounded("gust_frequency", 1e4, "Hz");
      d.finish();
      scene.setup.drag = ds;
    }
    if (e.has("wind")) scene.setup.wind = parse_wind(e.object("wind"));
    e.finish();
  }
}

// `constraints` (StrainLimitStage.h, TetherStage.h), then the tier's passes where the scene names none of
// that kind, and `body_contact`.
void parse_constraints(const JsonReader& r, Scene& scene) {
  const QualityTier& tier = scene.quality;
  if (r.has("constraints")) {
    // Constraint passes after the solver (StrainLimitStage.h, TetherStage.h); only the named ones exist.
    const JsonReader k = r.object("constraints");
    if (k.has("strain_limit")) {
      const JsonReader sl = k.object("strain_limit");
      cloth::StrainLimitSettings s;
      s.max_stretch = sl.number("max_stretch", s.max_stretch, 0.0);
      // The engine's own bound (Simulation.h), checked here so that the message names the scene file.
      if (!(s.max_stretch < 1e6))
        sl.fail("max_stretch", "must be below 1e6 (a stretch ratio; got " + show(s.max_stretch) + ")");
      s.iterations = sl.integer("iterations", s.iterations, 1, 100000);
      sl.finish();
      scene.setup.strain_limit = s;
    }
    if (k.has("tethers")) {
      const JsonReader t = k.object("tethers");
      cloth::TetherSettings s;
      s.slack = t.number("slack", s.slack, 0.0);
      if (!(s.slack < 1e6)) t.fail("slack", "must be below 1e6 (got " + show(s.slack) + ")");
      s.geodesic = t.string("distance", "geodesic", {"geodesic", "euclidean"}) == "geodesic";
      t.finish();
      scene.setup.tethers = s;
    }
    k.finish();
  }
  // The tier's constraint passes, where the scene names none of that kind.
  if (tier.strain_limit && !scene.setup.strain_limit)
    scene.strain_limit_after_contact = cloth::StrainLimitSettings{0.1, 2};
  if (tier.tethers && !scene.setup.tethers) scene.setup.tethers = cloth::TetherSettings{0.1, true};
  scene.realtime_contact = r.string("body_contact", tier.realtime_contact ? "realtime" : "exact",
                                    {"realtime", "exact"}) == "realtime";
}

// `cloths[i].pressure`: gas pressure inside a closed mesh (PressureTerm.h).
cloth::PressureSettings parse_pressure(const JsonReader& p, const cloth::ClothMesh& mesh) {
  cloth::PressureSettings ps;
  ps.ideal_gas = p.string("model", "constant", {"constant", "ideal_gas"}) == "ideal_gas";
  ps.overpressure = p.number("overpressure");
  ps.ambient = p.number("ambient", ps.ambient, 0.0);
  if (p.has("ambient") && !ps.ideal_gas)
    p.fail("ambient", "only the ideal_gas model uses the ambient pressure");
  p.finish();
  ps.validate(p.file(), p.path());
  const std::string open = cloth::closed_mesh_problem(static_cast<int>(mesh.edges().size()),
                                                      static_cast<int>(mesh.hinges().size()));
  if (!open.empty()) throw Error(p.file(), p.path(), open);
  return ps;
}

// The character's garments first (SceneCharacter.cpp), then `cloths`.
void parse_cloths(const JsonReader& r, Scene& scene, const std::string& file) {
  parse_character(r, scene);  // Mocap character; its garments are the first cloths (SceneCharacter.cpp)
  const auto cloths =
      r.has("cloths") || scene.setup.cloths.empty() ? r.objects("cloths") : std::vector<JsonReader>{};
  if (cloths.empty() && scene.setup.cloths.empty()) r.fail("cloths", "a scene needs at least one cloth");
  if (cloths.size() > kMaxCloths)
    r.fail("cloths", "has " + std::to_string(cloths.size()) + " entries; at most " +
                         std::to_string(kMaxCloths) + " are allowed");
  for (const JsonReader& c : cloths) {
    cloth::ClothSetup cs;
    cs.name = c.name("name", "cloth" + std::to_string(scene.setup.cloths.size()));
    cs.mesh = parse_mesh(c.object("mesh"), scene);
    cs.material = parse_material(c, file);
    cs.model = c.string("model", "springs", cloth::model_names());
    if (c.has("mass")) {
      const double mass = c.number("mass", std::nullopt, 0.0, true);
      cs.material.areal_density = mass / cs.mesh->total_area();
      if (!std::isfinite(cs.material.areal_density) || !(cs.material.areal_density >= 1e-6) ||
          cs.material.areal_density > 1e4)
        c.fail("mass", "gives an areal density of " + show(cs.material.areal_density) +
                           " kg/m^2 over the mesh's " + show(cs.mesh->total_area()) +
                           " m^2; it must be in [1e-06, 10000]");
    }
    cs.initial_velocity = c.vec3("velocity", Vec3::Zero());
    // As a rigid body's: a start speed above kMaxStartSpeed carries the cloth beyond the coordinate bound
    // within seconds and its kinetic energy beyond what float32 outputs hold.
    if (!(cs.initial_velocity.norm() <= kMaxStartSpeed))
      c.fail("velocity", "must be at most " + show(kMaxStartSpeed) + " m/s (got " +
                             show(cs.initial_velocity.norm()) + " m/s)");
    if (c.has("pressure")) cs.pressure = parse_pressure(c.object("pressure"), *cs.mesh);
    // A pin moved at speed v strains the cloth behind it by about v / c, c = sqrt(E / rho) the speed of
    // stretch waves (E the 2D Young's modulus, N/m; rho the areal density): the strain a bar's end carries
    // when it is set moving at v (longitudinal impact; Graff 1975, Wave Motion in Elastic Solids). Past
    // the guard's strain bound the run would only stop, so the path is refused here, by its field.
    const double wave_speed =
        std::sqrt(std::min(cs.material.stretch_weft, cs.material.stretch_warp) / cs.material.areal_density);
    const double max_pin_speed = scene.setup.guard.max_strain * wave_speed;
    cs.pins = parse_pins(c, *cs.mesh, max_pin_speed,
                         "(guard.max_strain " + show(scene.setup.guard.max_strain) +
                             " x the cloth's stretch-wave speed " + show(wave_speed) + " m/s)",
                         cs.pin_fields);
    if (c.has("detail")) {  // Hybrid detail (CurvedFaces.h)
      const cloth::DetailSettings ds = parse_detail(c.object("detail"));
      scene.detail[static_cast<int>(scene.setup.cloths.size())] = ds;
      // The shown surface has about 4^levels times the cloth's vertices; each costs about a quarter of a
      // simulated vertex (positions, normals and the curved-face coefficients, no solver state).
      reserve_vertices(scene, c.child("detail") + ".levels",
                       0.25 * cs.mesh->num_vertices() * std::pow(4.0, ds.levels));
    }
    c.finish();
    scene.setup.cloths.push_back(std::move(cs));
    scene.cloth_fields.push_back(c.path());
  }
}

// `output`: OBJ frames, export formats and the renderer's settings.
void parse_output(const JsonReader& r, Scene& scene) {
  if (r.has("output")) {
    const JsonReader o = r.object("output");
    scene.output.every = o.integer("every", 1, 1);
    scene.output.frames = o.boolean("frames", true);
    if (o.has("formats")) {
      const nlohmann::json& f = o.raw("formats");
      if (!f.is_array()) o.fail("formats", "expected an array of format names (\"obj\", \"pc2\", \"gltf\")");
      scene.output.formats.clear();
      for (size_t i = 0; i < f.size(); ++i) {
        const std::string where = "formats[" + std::to_string(i) + "]";
        if (!f[i].is_string()) o.fail(where, "expected a format name (\"obj\", \"pc2\", \"gltf\")");
        const std::string name = f[i].get<std::string>();
        if (name != "obj" && name != "pc2" && name != "gltf")
          o.fail(where, "unknown format '" + show_value(name) + "' (known: obj, pc2, gltf)");
        if (std::find(scene.output.formats.begin(), scene.output.formats.end(), name) !=
            scene.output.formats.end())
          o.fail(where, "format '" + show_value(name) + "' is listed twice");
        scene.output.formats.push_back(name);
      }
    }
    if (o.has("render")) {
      const JsonReader rr = o.object("render");
      RenderOutput& ro = scene.output.render;
      ro.width = rr.integer("width", 640, 16, 8192);
      ro.height = rr.integer("height", 480, 16, 8192);
      // The GIF preview is scaled to 320 px wide (RunCommand.cpp): its height must be one GIF holds.
      const double gif_height = 320.0 * ro.height / ro.width;
      if (!(gif_height >= 2.0 && gif_height <= 65535.0))
        rr.fail("height", "with width " + std::to_string(ro.width) +
                              " the 320 px wide GIF preview would be " + show(gif_height) +
                              " px tall; a GIF holds 2 to 65535 (height / width in [1/160, 204])");
      ro.every = rr.integer("every", 1, 1);
      if (rr.has("camera")) {
        const JsonReader c = rr.object("camera");
        ro.camera = true;
        ro.eye = c.point("eye");  // within the scene's coordinate bound, as every position
        ro.target = c.point("target");
        ro.fov = c.number("fov", 40.0, 0.0, true);
        if (ro.fov >= 170.0) c.fail("fov", "must be < 170 degrees");
        if ((ro.eye - ro.target).norm() < 1e-9) c.fail("target", "must differ from camera.eye");
        c.finish();
      }
      rr.finish();
    }
    o.finish();
  }
}

// Weil's drape is one static shape from catenaries (WeilSolver.h): no motion, no contact.
void check_weil(const Scene& scene, const std::string& file) {
  if (scene.setup.solver.method == "weil") {
    // Weil's drape is one static shape from catenaries (WeilSolver.h): no motion, no contact.
    auto refuse = [&](const std::string& field, const std::string& what) {
      throw Error(file, field,
                  "the weil drape (solver.method \"weil\") is a static geometric shape without " + what +
                      ": use a dynamic solver or the static solver");
    };
    if (!scene.colliders.empty()) refuse("colliders", "collision");
    if (!scene.bodies.empty()) refuse("bodies", "collision or rigid bodies");
    if (scene.character) refuse("character", "motion (a character moves)");
    if (scene.collision) refuse("collision", "collision");
    if (scene.frames > 1)
      refuse("duration", "dynamics: it gives one frame (set duration to 1/fps; got " +
                             std::to_string(scene.frames) + " frames)");
  }
}

// Exact cloth-cloth collision (continuous tests, impact zones) keeps cloths on the sides they start on: two
// cloths that start on top of each other (a cloth given twice) have no sides, and their impact zones go
// rigid at every step. A vertex of one cloth closer than a thousandth of the thinner one's thickness to a
// vertex of another is refused (a 3x3x3-cell hash of the vertices: linear in their number).
void check_coincident_cloths(const Scene& scene, const std::string& file) {
  if (!scene.collision || scene.proximity || scene.setup.cloths.size() < 2) return;
  double thickness = HUGE_VAL;
  for (const cloth::ClothSetup& c : scene.setup.cloths) thickness = std::min(thickness, c.material.thickness);
  const double tol = 1e-3 * thickness;
  if (!(tol > 0.0)) return;
  struct Key {
    long long x, y, z;
    bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      return std::hash<long long>()(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
    }
  };
  auto key_of = [&](const cloth::Vec3& p) {
    return Key{static_cast<long long>(std::floor(p.x() / tol)),
               static_cast<long long>(std::floor(p.y() / tol)),
               static_cast<long long>(std::floor(p.z() / tol))};
  };
  std::unordered_map<Key, std::vector<std::pair<int, int>>, KeyHash> cells;  // cell -> (cloth, vertex)
  for (size_t c = 0; c < scene.setup.cloths.size(); ++c) {
    const cloth::Vec3s& x = scene.setup.cloths[c].mesh->rest_positions();
    for (int v = 0; v < static_cast<int>(x.size()); ++v) {
      if (!(x[v].cwiseAbs().maxCoeff() < 1e15 * tol)) continue;  // beyond the hash's range: not coincident
      const Key k = key_of(x[v]);
      for (long long dz = -1; dz <= 1; ++dz)
        for (long long dy = -1; dy <= 1; ++dy)
          for (long long dx = -1; dx <= 1; ++dx) {
            const auto it = cells.find(Key{k.x + dx, k.y + dy, k.z + dz});
            if (it == cells.end()) continue;
            for (const auto& [oc, ov] : it->second) {
              if (oc == static_cast<int>(c)) continue;
              const cloth::Vec3& q = scene.setup.cloths[oc].mesh->rest_positions()[ov];
              if ((q - x[v]).norm() >= tol) continue;
              throw Error(
                  file, scene.cloth_field(static_cast<int>(c)),
                  "starts on top of " + scene.cloth_field(oc) + " (its vertex " + std::to_string(v) + " is " +
                      show((q - x[v]).norm()) + " m from vertex " + std::to_string(ov) +
                      "): cloth-cloth collision keeps cloths on the sides they start on, so they must "
                      "start apart; move one by at least its thickness");
            }
          }
      cells[k].push_back({static_cast<int>(c), v});
    }
  }
}

// The static solver finds an equilibrium (StaticSolver.h): under gravity a cloth that nothing holds (no
// pin, no body or character attachment) has none, and the Newton steps would carry it away without bound.
// Its energy has no contact term either: a collider, a body, a character's capsules or cloth-cloth collision
// would be projected after each equilibrium, which the next one undoes (a sphere under a pinned sheet made
// every Newton solve diverge).
void check_static(const Scene& scene, const std::string& file) {
  if (scene.setup.solver.method != "static") return;
  auto refuse = [&](const std::string& field, const std::string& what) {
    throw Error(
        file, field,
        "the static solver (solver.method \"static\") minimises the cloth's potential energy, which has "
        "no contact term: it cannot take " +
            what + " (use a dynamic solver)");
  };
  if (!scene.colliders.empty()) refuse("colliders", "colliders");
  if (!scene.bodies.empty()) refuse("bodies", "rigid bodies");
  if (scene.character) refuse("character", "a character's capsules");
  if (scene.collision) refuse("collision", "collision");
  // Every step is an equilibrium: a cloth needs a load, and a start velocity has nothing to act on. The
  // loads this solver takes are gravity and moving pins (a pin whose target leaves its vertex's start: an
  // anchor elsewhere or a path); wind, drag and pressure are not conservative (StaticSolver::check).
  for (size_t i = 0; i < scene.setup.cloths.size(); ++i) {
    const cloth::ClothSetup& c = scene.setup.cloths[i];
    const std::string at = "cloths[" + std::to_string(i) + "]";
    if (c.initial_velocity.norm() != 0.0)
      throw Error(
          file, at + ".velocity",
          "the static solver (solver.method \"static\") finds an equilibrium at every step and keeps no "
          "velocity: it cannot take a start velocity (remove it or use a dynamic solver)");
    if (scene.setup.gravity.norm() != 0.0) continue;
    bool pin_moves = false;
    for (const cloth::PinSpec& p : c.pins) {
      if (p.vertex < 0 || p.vertex >= c.mesh->num_vertices()) continue;
      const cloth::Vec3 start = c.mesh->rest_positions()[p.vertex];
      pin_moves = pin_moves || (p.anchor && (*p.anchor - start).norm() != 0.0);
      for (const cloth::Vec3& o : p.offsets) pin_moves = pin_moves || o.norm() != 0.0;
    }
    if (!pin_moves)
      throw Error(
          file, "gravity",
          "is [0, 0, 0] and nothing else loads cloth '" + c.name +
              "' (no pin of it moves: the static solver (solver.method \"static\") takes no wind, drag "
              "or pressure), so its equilibrium is where it starts and the solver has nothing to "
              "solve: give gravity, move a pin (" +
              at + ".pins[k].path) or use a dynamic solver");
  }
  if (scene.setup.gravity.norm() == 0.0) return;
  for (size_t i = 0; i < scene.setup.cloths.size(); ++i) {
    bool held = !scene.setup.cloths[i].pins.empty();
    for (const collision::RigidBodySpec& b : scene.bodies)
      for (const collision::BodyAttachment& a : b.attachments) held = held || a.cloth == static_cast<int>(i);
    if (!held)
      throw Error(
          file, "cloths[" + std::to_string(i) + "].pins",
          "the static solver (solver.method \"static\") needs a held cloth: cloth '" +
              scene.setup.cloths[i].name +
              "' has no pin and no attachment, so under gravity it has no equilibrium (pin it or use a "
              "dynamic solver)");
  }
}

// A cloth's model against the method that will run it: the coupled solve of a Bullet world and the
// position-based and projective solvers take the springs model only (Solver.h, takes_springs_only), so
// another model is refused by the cloth's `model`, naming who picked the method.
void check_models(const JsonReader& r, const Scene& scene, const std::string& file) {
  const bool method_given = r.has("solver") && r.object("solver").has("method");
  const std::string& method = scene.setup.solver.method;
  for (size_t i = 0; i < scene.setup.cloths.size(); ++i) {
    const std::string& model = scene.setup.cloths[i].model;
    if (model == "springs") continue;
    const std::string field = scene.cloth_field(static_cast<int>(i)) + ".model";
    if (scene.world.coupled)
      throw Error(file, field,
                  "'" + model + "' cannot run in the coupled solve of a Bullet world (quality \"" +
                      scene.quality.name +
                      "\"), which takes the springs model only: use \"springs\", or run the setup tier "
                      "with \"quality\": \"reference\"");
    if (cloth::takes_springs_only(method))
      throw Error(
          file, field,
          "'" + model + "' cannot run with solver.method '" + method + "' (" +
              (method_given ? std::string("the scene's")
                            : "picked by \"quality\": \"" + scene.quality.name + "\"") +
              "), which takes the springs model only: use \"springs\", or a solver that takes it "
              "(implicit_euler, bdf2, imex or an explicit one; \"quality\": \"reference\" picks one)");
  }
}

// A scene with `bodies`: how its cloths run in the Bullet world (SceneQuality.h, WorldTier). In the coupled
// tier the bridge solves cloth, contacts, edges and tethers together, so the tier's tether pass is dropped
// and the explicit values that apply become its settings.
void parse_world_tier(const JsonReader& r, Scene& scene) {
  if (scene.bodies.empty()) return;
  // The bridge runs its own cloth-body contact in every tier (BulletCloth.h, Contacts).
  if (r.has("body_contact"))
    r.fail("body_contact",
           "is not used in a Bullet world (a scene with 'bodies'), whose cloth-body contact is the Bullet "
           "bridge's own whatever the quality (docs/bullet.md); remove it");
  WorldTier w = world_tier(scene.quality.name);
  const std::string method = scene.setup.solver.method;
  const bool solver_given = r.has("solver") && r.object("solver").has("method");
  if (w.coupled && solver_given && method != "pbd" && method != "xpbd" && method != "fast_xpbd")
    w.coupled = false;  // the scene's own solver wins: the setup tier runs it
  scene.world = w;
  if (!w.coupled) return;
  WorldTier& out = scene.world;
  if (solver_given) out.solver = method;
  if (r.has("solver")) {
    const JsonReader s = r.object("solver");
    if (s.has("iterations")) out.iterations = static_cast<int>(scene.setup.solver.params.at("iterations"));
    if (s.has("substeps") || s.has("dt")) out.substeps = scene.setup.substeps;
    for (const auto& [key, value] : scene.setup.solver.params)
      if (key != "iterations" && s.has(key))
        s.fail(key, "is not used by the coupled solve of a Bullet world (quality \"" + scene.quality.name +
                        "\"); remove it, or run the setup tier with \"quality\": \"reference\"");
  }
  if (r.has("constraints")) {
    const JsonReader k = r.object("constraints");
    if (k.has("strain_limit") && k.object("strain_limit").has("max_stretch"))
      out.max_stretch = scene.setup.strain_limit->max_stretch;
    if (k.has("tethers")) {
      const JsonReader t = k.object("tethers");
      if (t.has("distance"))
        t.fail("distance", "is not used by the coupled solve of a Bullet world (its tethers run to the " +
                               std::string("nearest pins); remove it, or set \"quality\": \"reference\""));
      if (t.has("slack")) out.tether_stretch = scene.setup.tethers->slack;
    }
  }
  scene.setup.tethers.reset();  // the coupled solve's own tethers
  scene.strain_limit_after_contact.reset();
}

}  // namespace

Scene parse_scene(const nlohmann::json& written, const std::string& file) {
  const nlohmann::json root =
      whole_numbers_as_integers(written);  // 4.0 is the integer 4 (JSON has one number)
  const JsonReader r(root, "", file);
  Scene scene;
  parse_header(r, scene, file);
  parse_solver(r, root, scene, file);
  parse_effects(r, scene);
  parse_constraints(r, scene);
  parse_cloths(r, scene, file);
  parse_bodies(r, scene);      // Bullet rigid bodies (SceneBodies.cpp)
  parse_colliders(r, scene);   // Rigid colliders and their motion (SceneColliders.cpp)
  parse_collision(r, scene);   // Self- and cloth-cloth collision, friction pairs (SceneCollision.cpp)
  parse_world_tier(r, scene);  // a Bullet world's tier (SceneQuality.h)
  check_models(r, scene, file);

  parse_output(r, scene);
  r.finish();
  check_weil(scene, file);
  check_static(scene, file);
  check_coincident_cloths(scene, file);
  const bool halvings_given = root.is_object() && root.contains("guard") && root["guard"].is_object() &&
                              root["guard"].contains("max_halvings");
  for (const RegimeOutlier& o : regime_outliers(scene)) {
    if (!halvings_given && !o.step_bound)
      scene.setup.guard.max_halvings = std::min(scene.setup.guard.max_halvings, kRegimeOutsideHalvings);
    if (o.start) scene.start_warnings.push_back(o.text);
  }
  return scene;
}

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides) {
  nlohmann::json root = read_json_file(path);
  for (const std::string& o : overrides) apply_override(root, o, path);
  return parse_scene(root, path);
}

}  // namespace loom::scene
