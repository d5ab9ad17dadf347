#include "loom/scene/SceneColliders.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "loom/cloth/Error.h"
#include "loom/cloth/InputFile.h"
#include "loom/cloth/ObjFile.h"
#include "loom/collision/ColliderGeometry.h"
#include "loom/scene/SceneLimits.h"

namespace loom::scene {

namespace {

using cloth::Vec3;
using collision::Collider;
using collision::ShapeType;
using collision::Transform;

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// The unit vector along `key` of `o`: scaled by its largest component first, so an axis whose length
// overflows double (or underflows to 0) still has its direction.
Vec3 unit_axis(const JsonReader& o, const std::string& key) {
  Vec3 axis = o.vec3(key);
  const double largest = axis.cwiseAbs().maxCoeff();
  if (!(largest > 0.0)) o.fail(key, "must not be zero");
  axis /= largest;
  return axis.normalized();
}

const std::string kCoordinateLimit = std::to_string(static_cast<long>(kMaxCoordinate));

// A point (position, vertex, centre) with every coordinate within +-kMaxCoordinate m.
void check_point(const JsonReader& r, const std::string& key, const Vec3& p) {
  if (!(p.cwiseAbs().maxCoeff() <= kMaxCoordinate))
    r.fail(key, "coordinates must be within +-" + kCoordinateLimit + " m");
}

// Refuses a triangle of zero area (repeated or collinear vertices), the cloth mesh's test (ClothMesh.cpp):
// its normal is undefined, so contacts against it are too.
bool degenerate(const std::vector<Vec3>& x, const cloth::Tri& t) {
  if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return true;
  const Vec3 e1 = x[t[1]] - x[t[0]], e2 = x[t[2]] - x[t[0]];
  const double longest = std::max({e1.squaredNorm(), e2.squaredNorm(), (e2 - e1).squaredNorm()});
  return !(e1.cross(e2).norm() > 1e-10 * longest);
}

// The triangles seen so far by their three vertices (in any order and winding): a triangle repeated (the
// same face twice, or once per side) gives a two-sided mesh collider two coincident faces whose contacts
// count twice and whose normals may oppose each other.
class TriangleSet {
 public:
  // The index of the earlier triangle with the vertices of `t`, or -1 (and `t` is recorded as `index`).
  long long repeat_of(const cloth::Tri& t, long long index) {
    std::array<int, 3> key = {t[0], t[1], t[2]};
    std::sort(key.begin(), key.end());
    const auto [it, added] = seen_.emplace(key, index);
    return added ? -1 : it->second;
  }

 private:
  std::map<std::array<int, 3>, long long> seen_;
};

// `rotation`: {"axis": [x, y, z], "degrees": a} (right-handed about the axis).
Eigen::Matrix3d parse_rotation(const JsonReader& r, const std::string& key) {
  if (!r.has(key)) return Eigen::Matrix3d::Identity();
  const JsonReader o = r.object(key);
  const Vec3 axis = unit_axis(o, "axis");
  const double degrees = o.number("degrees");
  if (!(std::abs(degrees) <= kMaxDegrees))
    o.fail("degrees", "must be within +-1000000 degrees (got " + show_number(degrees, 9) + ")");
  o.finish();
  return Eigen::AngleAxisd(std::fmod(degrees, 360.0) * kDeg, axis).toRotationMatrix();
}

Transform parse_pose(const JsonReader& r) {
  Transform t = Transform::Identity();
  t.linear() = parse_rotation(r, "rotation");
  t.translation() = r.point("position", Vec3::Zero());
  return t;
}

std::vector<Vec3> parse_points(const JsonReader& r, const std::string& key) {
  const nlohmann::json& v = r.raw(key);
  if (!v.is_array() || v.empty()) r.fail(key, "expected an array of [x, y, z] points");
  std::vector<Vec3> out;
  for (size_t i = 0; i < v.size(); ++i) {
    const auto& p = v[i];
    if (!p.is_array() || p.size() != 3 || !p[0].is_number() || !p[1].is_number() || !p[2].is_number())
      r.fail(key + "[" + std::to_string(i) + "]", "expected [x, y, z]");
    out.emplace_back(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
    if (!out.back().allFinite()) r.fail(key + "[" + std::to_string(i) + "]", "must be finite");
    check_point(r, key + "[" + std::to_string(i) + "]", out.back());
  }
  return out;
}

// Collider geometry from an OBJ file (the one strict reader, ObjFile.h): vertices times `scale`, polygons
// fan-split. Errors name the OBJ file and line.
void read_obj(const std::string& path, double scale, std::vector<Vec3>& vertices,
              std::vector<cloth::Tri>& tris) {
  const cloth::ObjFile obj = cloth::read_obj_file(path);
  for (size_t i = 0; i < obj.positions.size(); ++i) {
    vertices.push_back(scale * obj.positions[i]);
    if (!(vertices.back().cwiseAbs().maxCoeff() <= kMaxCoordinate))
      throw Error(path,
                  "line " + std::to_string(obj.position_lines[i]) + " (vertex " + std::to_string(i + 1) + ")",
                  "times the scale, it is beyond +-" + kCoordinateLimit + " m");
  }
  // Errors name the face's line; a polygon's fan triangle by its corners (1-based, as in the face).
  std::vector<const cloth::ObjFace*> face_of;  // the face each triangle came from
  auto corners = [](const cloth::ObjFace& f, size_t j) {
    return f.corners.size() == 3 ? std::string("the face")
                                 : "the face's triangle of corners 1, " + std::to_string(j + 1) + " and " +
                                       std::to_string(j + 2);
  };
  TriangleSet seen;
  for (const cloth::ObjFace& f : obj.faces) {
    for (size_t j = 1; j + 1 < f.corners.size(); ++j) {
      tris.push_back({f.corners[0].v, f.corners[j].v, f.corners[j + 1].v});
      face_of.push_back(&f);
      if (degenerate(vertices, tris.back()))
        throw Error(path, loom::line_where(f.line, f.text),
                    corners(f, j) + " has zero area (repeated or collinear vertices: a degenerate triangle)");
      const long long index = static_cast<long long>(tris.size()) - 1;
      if (const long long earlier = seen.repeat_of(tris.back(), index); earlier >= 0)
        throw Error(path, loom::line_where(f.line, f.text),
                    corners(f, j) + " repeats a triangle of the face at " +
                        loom::line_where(face_of[earlier]->line, face_of[earlier]->text) +
                        " (the same three vertices): a mesh collider's faces must be distinct");
    }
  }
  if (vertices.empty()) throw Error(path, "", "no vertices");
}

// Kinematic motion: `keyframes` (piecewise linear position, slerp rotation, held before the first and
// after the last), or `velocity` (m/s) and/or `spin` {axis, rate (rad/s), centre (m, default: position)}:
// pose(t) = translate(velocity t) * rotate_about(centre, axis, rate t) * pose(0).
std::function<Transform(double)> parse_motion(const JsonReader& m, const Transform& start, double duration) {
  if (m.has("keyframes")) {
    if (m.has("velocity") || m.has("spin"))
      m.fail("keyframes", "give either 'keyframes' or 'velocity'/'spin', not both");
    std::vector<double> times;
    std::vector<Transform> poses;
    for (const JsonReader& k : m.objects("keyframes")) {
      times.push_back(k.number("t"));
      Transform p = Transform::Identity();
      p.linear() = k.has("rotation") ? parse_rotation(k, "rotation") : Eigen::Matrix3d(start.linear());
      p.translation() = k.point("position", start.translation());
      k.finish();
      if (times.size() > 1 && !(times.back() > times[times.size() - 2]))
        k.fail("t", "keyframe times must increase strictly");
      if (!poses.empty()) {
        check_keyframe_speed(k, times[times.size() - 2], times.back(), poses.back().translation(),
                             p.translation());
        // The turn between keyframes (slerp: the shortest angle) at most kMaxSpeed rad/s, as a spin.
        const double angle = Eigen::AngleAxisd(poses.back().linear().transpose() * p.linear()).angle();
        if (!(angle <= kMaxSpeed * (times.back() - times[times.size() - 2])))
          k.fail("rotation", "turns " + show_count(angle) + " rad in " +
                                 show_count(times.back() - times[times.size() - 2]) +
                                 " s after the keyframe before: at most " +
                                 std::to_string(static_cast<long>(kMaxSpeed)) + " rad/s between keyframes");
      }
      poses.push_back(p);
    }
    if (times.empty()) m.fail("keyframes", "needs at least one keyframe");
    m.finish();
    return [times, poses](double t) {
      if (t <= times.front()) return poses.front();
      if (t >= times.back()) return poses.back();
      const size_t k = std::upper_bound(times.begin(), times.end(), t) - times.begin();
      const double a = (t - times[k - 1]) / (times[k] - times[k - 1]);
      Transform out = Transform::Identity();
      out.linear() = Eigen::Quaterniond(poses[k - 1].linear())
                         .slerp(a, Eigen::Quaterniond(poses[k].linear()))
                         .toRotationMatrix();
      out.translation() = (1.0 - a) * poses[k - 1].translation() + a * poses[k].translation();
      return out;
    };
  }
  const Vec3 velocity = m.vec3("velocity", Vec3::Zero());
  // Where the velocity takes the collider by the end of the run must stay within the bounds too.
  if (!((start.translation() + velocity * duration).cwiseAbs().maxCoeff() <= kMaxCoordinate))
    m.fail("velocity", "moves the collider beyond +-" + kCoordinateLimit + " m within the scene's duration");
  Vec3 axis = Vec3::UnitY(), centre = start.translation();
  double rate = 0.0;
  if (m.has("spin")) {
    const JsonReader s = m.object("spin");
    axis = unit_axis(s, "axis");
    rate = s.number("rate");
    if (!(std::abs(rate) <= kMaxSpeed))
      s.fail("rate", "must be within +-" + std::to_string(static_cast<long>(kMaxSpeed)) + " rad/s");
    centre = s.point("centre", centre);
    // The orbit about the centre stays within the coordinate bound (with what the velocity adds), and its
    // surface moves no faster than a keyframed path may.
    const double radius = (start.translation() - centre).norm();
    if (!(centre.cwiseAbs().maxCoeff() + radius + velocity.norm() * duration <= kMaxCoordinate))
      s.fail("centre", "puts the collider's orbit (radius " + show_number(radius) + " m) beyond +-" +
                           kCoordinateLimit + " m within the scene's duration");
    if (!(std::abs(rate) * radius <= kMaxSpeed))
      s.fail("rate", "moves the collider at " + show_number(std::abs(rate) * radius) +
                         " m/s about its centre " + show_number(radius) + " m away, above the " +
                         std::to_string(static_cast<long>(kMaxSpeed)) + " m/s a collider may move");
    s.finish();
  }
  m.finish();
  return [start, velocity, axis, rate, centre](double t) {
    Transform spin = Transform::Identity();
    spin.linear() = Eigen::AngleAxisd(rate * t, axis).toRotationMatrix();
    spin.translation() = centre - spin.linear() * centre;
    Transform out = spin * start;
    out.translation() += velocity * t;
    return out;
  };
}

}  // namespace

void parse_colliders(const JsonReader& root, Scene& scene) {
  if (!root.has("colliders")) return;
  const std::vector<JsonReader> list = root.objects("colliders");
  if (list.size() > kMaxColliders)
    root.fail("colliders", "has " + std::to_string(list.size()) + " entries; at most " +
                               std::to_string(kMaxColliders) + " are allowed");
  std::map<std::string, size_t> names;  // collider name -> its index in scene.colliders
  for (size_t j = 0; j < scene.colliders.size(); ++j) names.emplace(scene.colliders[j].name, j);
  for (size_t i = 0; i < list.size(); ++i) {
    const JsonReader& r = list[i];
    Collider c;
    c.name = r.name("name", "collider" + std::to_string(i));
    // collision.friction_pairs name colliders: two of one name would make a pair ambiguous.
    const auto [named, fresh] = names.emplace(c.name, scene.colliders.size());
    if (!fresh)
      r.fail("name", "'" + c.name + "' is also the name of colliders[" + std::to_string(named->second) +
                         "]: collider names must be unique (collision.friction_pairs name them)");
    const std::string shape =
        r.string("shape", std::nullopt, {"plane", "sphere", "capsule", "box", "cylinder", "convex", "mesh"});
    collision::Shape& s = c.shape;
    refuse_other_shape_keys(
        r, shape, {"radius", "half_height", "half_extents", "vertices", "obj", "triangles"}, "collider");
    if (shape == "plane") {
      s.type = ShapeType::plane;
    } else if (shape == "sphere") {
      s.type = ShapeType::sphere;
      s.radius = r.length("radius", std::nullopt, true);
    } else if (shape == "capsule" || shape == "cylinder") {
      s.type = shape == "capsule" ? ShapeType::capsule : ShapeType::cylinder;
      s.radius = r.length("radius", std::nullopt, true);
      s.half_height = r.length("half_height", std::nullopt, shape == "cylinder");
    } else if (shape == "box") {
      s.type = ShapeType::box;
      s.half_extents = r.vec3("half_extents");
      if (!(s.half_extents.minCoeff() > 0.0) || !(s.half_extents.maxCoeff() <= kMaxCoordinate))
        r.fail("half_extents", "all three must be in (0, " + kCoordinateLimit + "] m");
    } else {
      s.type = shape == "convex" ? ShapeType::convex : ShapeType::mesh;
      if (r.has("vertices") == r.has("obj")) r.fail("", "give either 'vertices' or 'obj'");
      if (r.has("obj")) {
        const std::filesystem::path p = input_file(scene, r.child("obj"), r.string("obj"));
        const double scale = r.length("scale", 1.0, true);
        if (scale < kMinMeshScale) {
          std::ostringstream limit;
          limit << "must be >= " << kMinMeshScale << " (got " << scale << ")";
          r.fail("scale", limit.str());
        }
        // Estimated from its `f` lines before it is parsed.
        ObjCounts counts;
        try {
          counts = count_obj_elements(p.string());
        } catch (const Error& e) {
          throw Error(scene.file, r.child("obj"), e.what());
        }
        reserve_collider_triangles(scene, r.child("obj"), counts.triangles);
        check_obj_reading(scene, r.child("obj"), counts);
        try {
          read_obj(p.string(), scale, s.vertices, s.triangles);
        } catch (const Error& e) {
          throw Error(scene.file, r.child("obj"), e.what());
        }
      } else {
        s.vertices = parse_points(r, "vertices");
        if (s.type == ShapeType::mesh) {
          const nlohmann::json& t = r.raw("triangles");
          if (!t.is_array() || t.empty())
            r.fail("triangles", "expected an array of [i, j, k] vertex indices");
          TriangleSet seen;
          for (size_t k = 0; k < t.size(); ++k) {
            const auto& e = t[k];
            const std::string where = "triangles[" + std::to_string(k) + "]";
            if (!e.is_array() || e.size() != 3 || !e[0].is_number_integer() || !e[1].is_number_integer() ||
                !e[2].is_number_integer())
              r.fail(where, "expected [i, j, k]");
            // Checked as 64-bit values before narrowing: 2^32 + 1 is out of range, not 1.
            const long long last = static_cast<long long>(s.vertices.size()) - 1;
            cloth::Tri tri;
            for (int j = 0; j < 3; ++j)
              tri[j] = static_cast<int>(
                  r.integer_value(e[j], r.child(where) + "[" + std::to_string(j) + "]", 0, last));
            s.triangles.push_back(tri);
            if (degenerate(s.vertices, tri))
              r.fail(where, "triangle " + std::to_string(k) +
                                " has zero area (repeated or collinear vertices: a degenerate triangle)");
            if (const long long earlier = seen.repeat_of(tri, static_cast<long long>(k)); earlier >= 0)
              r.fail(where, "repeats triangles[" + std::to_string(earlier) +
                                "] (the same three vertices): a mesh collider's faces must be distinct");
          }
        }
      }
      if (s.type == ShapeType::mesh && s.triangles.empty())
        r.fail(r.has("obj") ? "obj" : "triangles", "a mesh collider needs triangles");
      s.triangles = s.type == ShapeType::convex ? std::vector<cloth::Tri>{} : s.triangles;
      try {
        c.geometry = collision::build_collider_geometry(s, "");
      } catch (const Error& e) {
        throw Error(scene.file, r.path(), e.what());
      }
    }
    const Transform start = parse_pose(r);
    c.prev = c.curr = start;
    c.thickness = r.thickness("thickness", 0.0);
    c.friction = r.friction("friction", c.friction);
    c.static_friction = r.friction("static_friction", std::max(c.static_friction, c.friction));
    if (c.static_friction < c.friction) r.fail("static_friction", "must be >= friction");
    if (r.has("motion")) {
      c.motion = parse_motion(r.object("motion"), start, scene.duration);
      c.prev = c.curr = c.motion(0.0);
    }
    r.finish();
    scene.colliders.push_back(std::move(c));
  }
}

}  // namespace loom::scene
