#include "loom/scene/Scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "loom/cloth/Error.h"
#include "loom/cloth/Model.h"
#include "loom/scene/JsonReader.h"
#include "loom/scene/SceneBodies.h"
#include "loom/scene/SceneColliders.h"
#include "loom/scene/SceneCharacter.h"
#include "loom/scene/SceneCollision.h"
#include "loom/scene/SceneGuard.h"

namespace loom::scene {

using cloth::Vec3;

nlohmann::json read_json_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path, "", "cannot open scene file");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // Turn the byte offset into a line and column.
    const size_t at = std::min<size_t>(e.byte == 0 ? 0 : e.byte - 1, text.size());
    int line = 1, col = 1;
    for (size_t i = 0; i < at; ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    std::string what = e.what();
    const size_t p = what.find("syntax error");
    throw Error(path, "line " + std::to_string(line) + ", column " + std::to_string(col),
                "invalid JSON: " + (p == std::string::npos ? what : what.substr(p)));
  }
}

void apply_override(nlohmann::json& root, const std::string& assignment, const std::string& file) {
  const size_t eq = assignment.find('=');
  const std::string where = "--set " + assignment;
  if (eq == std::string::npos || eq == 0) throw Error(file, where, "expected PATH=VALUE");
  std::string path = assignment.substr(0, eq);
  const std::string value = assignment.substr(eq + 1);
  // cloths[0].x -> cloths.0.x
  for (char& c : path)
    if (c == '[' || c == ']') c = '.';
  std::vector<std::string> parts;
  std::stringstream ps(path);
  std::string part;
  while (std::getline(ps, part, '.'))
    if (!part.empty()) parts.push_back(part);
  if (parts.empty()) throw Error(file, where, "empty path");
  nlohmann::json* node = &root;
  for (size_t k = 0; k < parts.size(); ++k) {
    const std::string& key = parts[k];
    const bool last = k + 1 == parts.size();
    if (node->is_array()) {
      size_t used = 0;
      long idx = -1;
      try {
        idx = std::stol(key, &used);
      } catch (...) {
      }
      if (used != key.size() || idx < 0 || idx >= static_cast<long>(node->size()))
        throw Error(file, where, "'" + key + "' is not an index of the array (size " + std::to_string(node->size()) + ")");
      node = &(*node)[idx];
    } else {
      if (node->is_null()) *node = nlohmann::json::object();
      if (!node->is_object()) throw Error(file, where, "'" + key + "' goes inside a value that is not an object");
      if (!last && !node->contains(key)) (*node)[key] = nlohmann::json::object();
      node = &(*node)[key];
    }
  }
  nlohmann::json v;
  try {
    v = nlohmann::json::parse(value);
  } catch (...) {
    v = value;  // a bare word is a string
  }
  *node = v;
}

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
    p.thickness = c.number("thickness", p.thickness, 0.0);
    p.stretch_weft = c.number("stretch_weft", p.stretch_weft, 0.0, true);
    p.stretch_warp = c.number("stretch_warp", p.stretch_warp, 0.0, true);
    p.shear = c.number("shear", p.shear, 0.0);
    p.bending_weft = c.number("bending_weft", p.bending_weft, 0.0);
    p.bending_warp = c.number("bending_warp", p.bending_warp, 0.0);
    p.friction = c.number("friction", p.friction, 0.0);
    p.internal_damping = c.number("internal_damping", p.internal_damping, 0.0);
    c.finish();
    m = cloth::from_clo_style(p);
  }
  // A value that must be positive (> 0) or non-negative (>= 0).
  auto positive = [&](const char* key, double& field) { field = r.number(key, field, 0.0, true); };
  auto non_negative = [&](const char* key, double& field) { field = r.number(key, field, 0.0, false); };
  if (r.has("stretch")) m.stretch_weft = m.stretch_warp = r.number("stretch", std::nullopt, 0.0, true);
  positive("stretch_weft", m.stretch_weft);
  positive("stretch_warp", m.stretch_warp);
  non_negative("shear", m.shear);
  if (r.has("bend")) m.bend_weft = m.bend_warp = r.number("bend", std::nullopt, 0.0, false);
  non_negative("bend_weft", m.bend_weft);
  non_negative("bend_warp", m.bend_warp);
  positive("areal_density", m.areal_density);
  non_negative("damping", m.damping);
  non_negative("friction", m.friction);
  non_negative("thickness", m.thickness);
  r.finish();
  return m;
}

namespace {

std::shared_ptr<const cloth::ClothMesh> parse_mesh(const JsonReader& r, const std::string& file) {
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
        if (!(size[k] > 0.0)) r.fail("size", "both sizes must be > 0");
      g.size_u = size[0];
      g.size_v = size[1];
      const nlohmann::json& nodes = r.raw("nodes");
      if (!nodes.is_array() || nodes.size() != 2 || !nodes[0].is_number_integer() || !nodes[1].is_number_integer())
        r.fail("nodes", "expected two integers [nodes_u, nodes_v]");
      g.nodes_u = nodes[0].get<int>();
      g.nodes_v = nodes[1].get<int>();
      if (g.nodes_u < 2 || g.nodes_v < 2 || g.nodes_u > 4096 || g.nodes_v > 4096)
        r.fail("nodes", "each count must be in [2, 4096]");
      const std::string plane = r.string("plane", "xz", {"xy", "xz", "yz"});
      g.plane = plane == "xy" ? cloth::GridPlane::kXY : plane == "yz" ? cloth::GridPlane::kYZ : cloth::GridPlane::kXZ;
      g.origin = r.vec3("origin", Vec3::Zero());
      r.finish();
      return build([&] { return cloth::ClothMesh::grid(g); });
    }
    std::string path = r.string("path");
    const double scale = r.number("scale", 1.0, 0.0, true);
    const Vec3 translate = r.vec3("translate", Vec3::Zero());
    r.finish();
    std::filesystem::path p(path);
    if (p.is_relative()) p = std::filesystem::path(file).parent_path() / p;
    return build([&] { return cloth::ClothMesh::from_obj(p.string(), scale, translate); });
  }
}

std::vector<cloth::PinSpec> parse_pins(const JsonReader& r, const cloth::ClothMesh& mesh) {
  std::vector<cloth::PinSpec> pins;
  if (!r.has("pins")) return pins;
  for (const JsonReader& p : r.objects("pins")) {
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
        pins.push_back(e);
      }
      continue;
    }
    if (p.has("vertex")) {
      spec.vertex = p.integer("vertex");
      if (spec.vertex < 0 || spec.vertex >= mesh.num_vertices())
        p.fail("vertex", "vertex " + std::to_string(spec.vertex) + " is out of range [0, " + std::to_string(mesh.num_vertices()) + ")");
    } else {
      if (!mesh.is_grid()) p.fail("grid", "grid pins need a grid mesh");
      const nlohmann::json& g = p.raw("grid");
      if (!g.is_array() || g.size() != 2 || !g[0].is_number_integer() || !g[1].is_number_integer())
        p.fail("grid", "expected [iu, iv] (negative counts from the far side)");
      int iu = g[0].get<int>(), iv = g[1].get<int>();
      if (iu < 0) iu += mesh.grid_nodes_u();
      if (iv < 0) iv += mesh.grid_nodes_v();
      if (iu < 0 || iu >= mesh.grid_nodes_u() || iv < 0 || iv >= mesh.grid_nodes_v())
        p.fail("grid", "node is outside the " + std::to_string(mesh.grid_nodes_u()) + "x" + std::to_string(mesh.grid_nodes_v()) + " grid");
      spec.vertex = mesh.grid_index(iu, iv);
    }
    if (p.has("anchor")) spec.anchor = p.vec3("anchor");
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
        if (!v.allFinite()) path.fail("offsets", "entry " + std::to_string(k) + " is not finite");
        spec.offsets.push_back(v);
      }
      for (size_t k = 1; k < spec.times.size(); ++k)
        if (!(spec.times[k] > spec.times[k - 1])) path.fail("times", "must increase strictly");
      path.finish();
    }
    p.finish();
    pins.push_back(spec);
  }
  return pins;
}

}  // namespace

cloth::DetailSettings parse_detail(const JsonReader& d) {
  cloth::DetailSettings ds;
  ds.method = d.string("method", "curved_faces", {"curved_faces"});
  ds.levels = d.integer("levels", 2, 0);
  if (ds.levels > 5) d.fail("levels", "must be <= 5 (each level multiplies the triangles by 4)");
  if (d.has("wrinkles")) {  // geometric wrinkles from the coarse compression (CurvedFaces.h)
    const JsonReader w = d.object("wrinkles");
    ds.wrinkles.enabled = true;
    ds.wrinkles.amplitude = w.number("amplitude", ds.wrinkles.amplitude, 0.0);
    ds.wrinkles.wavelength = w.number("wavelength", ds.wrinkles.wavelength, 0.0, true);
    w.finish();
  }
  d.finish();
  return ds;
}

Scene parse_scene(const nlohmann::json& root, const std::string& file) {
  const JsonReader r(root, "", file);
  Scene scene;
  scene.file = file;
  scene.name = r.string("name", std::filesystem::path(file).stem().string());
  if (r.has("description")) r.string("description");
  scene.duration = r.number("duration", 1.0, 0.0, true);
  const double fps = r.number("fps", 60.0, 0.0, true);
  if (fps > 100000.0) r.fail("fps", "must be <= 100000");
  scene.setup.frame_dt = 1.0 / fps;
  scene.frames = std::max(1, static_cast<int>(std::lround(scene.duration * fps)));
  scene.setup.gravity = r.vec3("gravity", Vec3(0.0, -9.81, 0.0));
  scene.setup.threads = r.integer("threads", 1, 1);
  parse_guard(r, scene.setup.guard);  // issue 8: non-finite / explosion guard (SceneGuard.cpp)

  // The quality tier (SceneQuality.h) gives the defaults of the solver, constraints and collision below.
  scene.quality = parse_quality(r);
  const QualityTier& tier = scene.quality;
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
      scene.setup.substeps = static_cast<int>(std::ceil(scene.setup.frame_dt / dt - 1e-9));
    } else {
      scene.setup.substeps = s.integer("substeps", 1, 1);
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

  if (r.has("effects")) {
    const JsonReader e = r.object("effects");
    if (e.has("drag")) {
      const JsonReader d = e.object("drag");
      cloth::DragSettings ds;
      ds.isotropic = d.number("isotropic", 0.0, 0.0);
      ds.normal = d.number("normal", 0.0, 0.0);
      ds.wind = d.vec3("wind", Vec3::Zero());
      ds.gust_amplitude = d.number("gust_amplitude", 0.0, 0.0);
      ds.gust_frequency = d.number("gust_frequency", 0.0, 0.0);
      d.finish();
      scene.setup.drag = ds;
    }
    e.finish();
  }

  if (r.has("constraints")) {
    // Constraint passes after the solver (StrainLimitStage.h, TetherStage.h); only the named ones exist.
    const JsonReader k = r.object("constraints");
    if (k.has("strain_limit")) {
      const JsonReader sl = k.object("strain_limit");
      cloth::StrainLimitSettings s;
      s.max_stretch = sl.number("max_stretch", s.max_stretch, 0.0);
      s.iterations = sl.integer("iterations", s.iterations, 1);
      if (s.iterations > 100000) sl.fail("iterations", "must be <= 100000");
      sl.finish();
      scene.setup.strain_limit = s;
    }
    if (k.has("tethers")) {
      const JsonReader t = k.object("tethers");
      cloth::TetherSettings s;
      s.slack = t.number("slack", s.slack, 0.0);
      s.geodesic = t.string("distance", "geodesic", {"geodesic", "euclidean"}) == "geodesic";
      t.finish();
      scene.setup.tethers = s;
    }
    k.finish();
  }
  // The tier's constraint passes, where the scene names none of that kind.
  if (tier.strain_limit && !scene.setup.strain_limit) scene.strain_limit_after_contact = cloth::StrainLimitSettings{0.1, 2};
  if (tier.tethers && !scene.setup.tethers) scene.setup.tethers = cloth::TetherSettings{0.1, true};
  scene.realtime_contact =
      r.string("body_contact", tier.realtime_contact ? "realtime" : "exact", {"realtime", "exact"}) == "realtime";

  parse_character(r, scene);  // issue 6: mocap character; its garments are the first cloths (SceneCharacter.cpp)
  const auto cloths = r.has("cloths") || scene.setup.cloths.empty() ? r.objects("cloths") : std::vector<JsonReader>{};
  if (cloths.empty() && scene.setup.cloths.empty()) r.fail("cloths", "a scene needs at least one cloth");
  for (const JsonReader& c : cloths) {
    cloth::ClothSetup cs;
    cs.name = c.string("name", "cloth" + std::to_string(scene.setup.cloths.size()));
    cs.mesh = parse_mesh(c.object("mesh"), file);
    cs.material = parse_material(c, file);
    cs.model = c.string("model", "springs", cloth::model_names());
    if (c.has("mass")) cs.material.areal_density = c.number("mass", std::nullopt, 0.0, true) / cs.mesh->total_area();
    cs.initial_velocity = c.vec3("velocity", Vec3::Zero());
    cs.pins = parse_pins(c, *cs.mesh);
    if (c.has("detail"))  // issue 10: hybrid detail (CurvedFaces.h)
      scene.detail[static_cast<int>(scene.setup.cloths.size())] = parse_detail(c.object("detail"));
    c.finish();
    scene.setup.cloths.push_back(std::move(cs));
  }
  parse_bodies(r, scene);  // issue 9: Bullet rigid bodies (SceneBodies.cpp)
  parse_colliders(r, scene);  // issue 5: rigid colliders and their motion (SceneColliders.cpp)
  parse_collision(r, scene);  // issue 5: self- and cloth-cloth collision, friction pairs (SceneCollision.cpp)

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
          o.fail(where, "unknown format '" + name + "' (known: obj, pc2, gltf)");
        if (std::find(scene.output.formats.begin(), scene.output.formats.end(), name) != scene.output.formats.end())
          o.fail(where, "format '" + name + "' is listed twice");
        scene.output.formats.push_back(name);
      }
    }
    if (o.has("render")) {
      const JsonReader rr = o.object("render");
      RenderOutput& ro = scene.output.render;
      ro.width = rr.integer("width", 640, 16);
      ro.height = rr.integer("height", 480, 16);
      if (ro.width > 8192) rr.fail("width", "must be <= 8192");
      if (ro.height > 8192) rr.fail("height", "must be <= 8192");
      ro.every = rr.integer("every", 1, 1);
      if (rr.has("camera")) {
        const JsonReader c = rr.object("camera");
        ro.camera = true;
        ro.eye = c.vec3("eye");
        ro.target = c.vec3("target");
        ro.fov = c.number("fov", 40.0, 0.0, true);
        if (ro.fov >= 170.0) c.fail("fov", "must be < 170 degrees");
        if ((ro.eye - ro.target).norm() < 1e-9) c.fail("target", "must differ from camera.eye");
        c.finish();
      }
      rr.finish();
    }
    o.finish();
  }
  r.finish();
  if (scene.setup.solver.method == "weil") {
    // Weil's drape is one static shape from catenaries (WeilSolver.h): no motion, no contact.
    auto refuse = [&](const std::string& field, const std::string& what) {
      throw Error(file, field, "the weil drape (solver.method \"weil\") is a static geometric shape without " + what +
                                   ": use a dynamic solver or the static solver");
    };
    if (!scene.colliders.empty()) refuse("colliders", "collision");
    if (!scene.bodies.empty()) refuse("bodies", "collision or rigid bodies");
    if (scene.character) refuse("character", "motion (a character moves)");
    if (scene.collision) refuse("collision", "collision");
    if (scene.frames > 1)
      refuse("duration", "dynamics: it gives one frame (set duration to 1/fps; got " + std::to_string(scene.frames) + " frames)");
  }
  return scene;
}

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides) {
  nlohmann::json root = read_json_file(path);
  for (const std::string& o : overrides) apply_override(root, o, path);
  return parse_scene(root, path);
}

}  // namespace loom::scene
