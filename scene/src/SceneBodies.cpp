#include "loom/scene/SceneBodies.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "loom/scene/SceneLimits.h"

namespace loom::scene {

using cloth::Vec3;
using collision::RigidBodySpec;
using collision::ShapeType;
using collision::Transform;

namespace {

// A number in a message, as written ("0.001", "1e+39").
std::string show_limit(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%.9g", v);
  return s;
}

// A body's radius or half height (m): in [kMinBodySize, kMaxCoordinate], so Bullet's float holds it and a
// body never has size 0.
double body_size(const JsonReader& r, const char* key) {
  const double v = r.number(key);
  if (!(v >= kMinBodySize && v <= kMaxCoordinate))
    r.fail(key, "must be in [" + show_limit(kMinBodySize) + ", " + show_limit(kMaxCoordinate) + "] m (got " +
                    show_limit(v) + ")");
  return v;
}

Transform parse_body_pose(const JsonReader& r) {
  Transform t = Transform::Identity();
  if (r.has("rotation")) {
    const JsonReader o = r.object("rotation");
    Vec3 axis = o.vec3("axis");
    // Scaled by its largest component before it is normalised: a huge axis (norm past double range) keeps
    // its direction instead of normalising to zero.
    const double largest = axis.cwiseAbs().maxCoeff();
    if (!(largest > 0.0)) o.fail("axis", "must not be zero");
    axis /= largest;
    const double degrees = o.number("degrees");
    if (!(std::abs(degrees) <= kMaxDegrees))
      o.fail("degrees", "must be within +-1000000 degrees (got " + show_number(degrees, 9) + ")");
    t.linear() =
        Eigen::AngleAxisd(std::fmod(degrees, 360.0) * M_PI / 180.0, axis.normalized()).toRotationMatrix();
    o.finish();
  }
  t.translation() = r.point("position", Vec3::Zero());
  return t;
}

// Kinematic motion: {"oscillate": {"amplitude": [m, m, m], "frequency": Hz, "twist": rad about y}} or
// {"keyframes": [{"t": s, "position": [..]}, ...]} (linear in between, held past the ends).
std::function<Transform(double)> parse_body_motion(const JsonReader& m, const Transform& start) {
  if (m.has("oscillate") == m.has("keyframes")) m.fail("", "give either 'oscillate' or 'keyframes'");
  if (m.has("oscillate")) {
    const JsonReader o = m.object("oscillate");
    const Vec3 amp = o.vec3("amplitude", Vec3::Zero());
    const double f = o.number("frequency", std::nullopt, 0.0, true);
    if (f > 1000.0) o.fail("frequency", "must be <= 1000 Hz");
    if (!(amp.cwiseAbs().maxCoeff() <= 1000.0)) o.fail("amplitude", "must be within 1000 m on each axis");
    const double twist = o.number("twist", 0.0);
    if (!(std::abs(twist) <= 100.0)) o.fail("twist", "must be within 100 rad");
    // The peak speeds 2 pi f |A| and 2 pi f |twist| are bounded as keyframed motion is (kMaxSpeed).
    if (!(2.0 * M_PI * f * amp.norm() <= kMaxSpeed))
      o.fail("amplitude", "with frequency " + show_count(f) + " Hz moves the body at up to " +
                              show_count(2.0 * M_PI * f * amp.norm()) + " m/s: at most " +
                              std::to_string(static_cast<long>(kMaxSpeed)) + " m/s");
    if (!(2.0 * M_PI * f * std::abs(twist) <= kMaxSpeed))
      o.fail("twist", "with frequency " + show_count(f) + " Hz turns the body at up to " +
                          show_count(2.0 * M_PI * f * std::abs(twist)) + " rad/s: at most " +
                          std::to_string(static_cast<long>(kMaxSpeed)) + " rad/s");
    o.finish();
    m.finish();
    return [start, amp, f, twist](double t) {
      const double s = std::sin(2.0 * M_PI * f * t);
      Transform out = start;
      out.translation() += amp * s;
      out.linear() = Eigen::AngleAxisd(twist * s, Vec3::UnitY()).toRotationMatrix() * start.linear();
      return out;
    };
  }
  std::vector<double> times;
  std::vector<Vec3> positions;
  for (const JsonReader& k : m.objects("keyframes")) {
    times.push_back(k.number("t"));
    positions.push_back(k.point("position"));
    k.finish();
    if (times.size() > 1 && !(times.back() > times[times.size() - 2]))
      k.fail("t", "keyframe times must increase strictly");
    if (times.size() > 1)
      check_keyframe_speed(k, times[times.size() - 2], times.back(), positions[positions.size() - 2],
                           positions.back());
  }
  if (times.empty()) m.fail("keyframes", "needs at least one keyframe");
  m.finish();
  return [start, times, positions](double t) {
    Transform out = start;
    if (t <= times.front()) {
      out.translation() = positions.front();
    } else if (t >= times.back()) {
      out.translation() = positions.back();
    } else {
      const size_t k = std::upper_bound(times.begin(), times.end(), t) - times.begin();
      const double a = (t - times[k - 1]) / (times[k] - times[k - 1]);
      out.translation() = (1.0 - a) * positions[k - 1] + a * positions[k];
    }
    return out;
  };
}

// m, how far past its bounding sphere a dynamic body may hold a cloth vertex.
constexpr double kAttachReach = 0.05;
// m, the largest bounding-sphere radius of a dynamic body (Bullet's AABB overflow is at 1e6 m across).
constexpr double kMaxDynamicBodyReach = 1e5;

// m, the radius of the sphere about the body's origin that holds the shape (a plane has none: infinite).
double bounding_radius(const collision::Shape& s) {
  switch (s.type) {
    case collision::ShapeType::sphere:
      return s.radius;
    case collision::ShapeType::capsule:
      return s.radius + s.half_height;
    case collision::ShapeType::box:
      return s.half_extents.norm();
    case collision::ShapeType::cylinder:
      return std::hypot(s.radius, s.half_height);
    default:
      return std::numeric_limits<double>::infinity();
  }
}

}  // namespace

void parse_bodies(const JsonReader& root, Scene& scene) {
  if (!root.has("bodies")) return;
  const auto bodies = root.objects("bodies");
  if (bodies.size() > kMaxBodies)
    root.fail("bodies", "has " + std::to_string(bodies.size()) + " entries; at most " +
                            std::to_string(kMaxBodies) + " are allowed");
  // (cloth, vertex) -> the attach entry that holds it: a vertex held twice (by one body or two) is refused.
  std::map<std::pair<int, int>, std::string> held;
  // Per cloth, vertex -> its first pin (-1: none), built when a body first attaches to the cloth.
  std::vector<std::vector<int>> pin_of(scene.setup.cloths.size());
  std::map<std::string, size_t> names;  // body name -> its index in bodies
  for (size_t i = 0; i < bodies.size(); ++i) {
    const JsonReader& r = bodies[i];
    RigidBodySpec b;
    b.name = r.name("name", "body" + std::to_string(i));
    // bodies.csv keys its rows by name: two bodies of one name could not be told apart.
    const auto [named, fresh] = names.emplace(b.name, i);
    if (!fresh)
      r.fail("name", "'" + b.name + "' is also the name of bodies[" + std::to_string(named->second) +
                         "]: body names must be unique (bodies.csv names its rows by them)");
    const std::string shape =
        r.string("shape", std::nullopt, {"plane", "sphere", "capsule", "box", "cylinder"});
    refuse_other_shape_keys(r, shape, {"radius", "half_height", "half_extents"}, "body");
    if (shape == "plane") {
      b.shape.type = ShapeType::plane;
    } else if (shape == "sphere") {
      b.shape.type = ShapeType::sphere;
      b.shape.radius = body_size(r, "radius");
    } else if (shape == "capsule" || shape == "cylinder") {
      b.shape.type = shape == "capsule" ? ShapeType::capsule : ShapeType::cylinder;
      b.shape.radius = body_size(r, "radius");
      b.shape.half_height = body_size(r, "half_height");
    } else {
      b.shape.type = ShapeType::box;
      b.shape.half_extents = r.vec3("half_extents");
      if (!(b.shape.half_extents.minCoeff() >= kMinBodySize) ||
          !(b.shape.half_extents.maxCoeff() <= kMaxCoordinate))
        r.fail("half_extents",
               "all three must be in [" + show_limit(kMinBodySize) + ", " + show_limit(kMaxCoordinate) +
                   "] m (got [" + show_limit(b.shape.half_extents.x()) + ", " +
                   show_limit(b.shape.half_extents.y()) + ", " + show_limit(b.shape.half_extents.z()) + "])");
    }
    b.pose = parse_body_pose(r);
    b.mass = r.number("mass", 0.0, 0.0);
    if (b.mass > 0.0 && shape == "plane") r.fail("mass", "a plane is static (mass 0)");
    // Bullet keeps the mass as a float: 1e-50 would be 0 (a static body), 1e39 infinite.
    if (b.mass != 0.0 && !(b.mass >= kMinBodyMass && b.mass <= kMaxBodyMass))
      r.fail("mass", "must be 0 (static) or in [" + show_limit(kMinBodyMass) + ", " +
                         show_limit(kMaxBodyMass) + "] kg (got " + show_limit(b.mass) + ")");
    // Bullet removes a moving body whose box is 1e6 m or more across from its simulation ("overflow in
    // AABB"): it would hang in the air. A dynamic body's bounding sphere is held below 1e5 m.
    if (b.mass > 0.0 && !(bounding_radius(b.shape) <= kMaxDynamicBodyReach))
      r.fail(shape == "box"      ? "half_extents"
             : shape == "sphere" ? "radius"
                                 : "half_height",
             "a dynamic body (mass > 0) must fit in a sphere of " + show_limit(kMaxDynamicBodyReach) +
                 " m (got " + show_limit(bounding_radius(b.shape)) +
                 " m; Bullet drops larger moving bodies from its world)");
    b.velocity = r.vec3("velocity", Vec3::Zero());
    if (!(b.velocity.norm() <= kMaxStartSpeed)) r.fail("velocity", "must be at most 1000 m/s");
    b.angular_velocity = r.vec3("angular_velocity", Vec3::Zero());
    if (!(b.angular_velocity.norm() <= 10000.0)) r.fail("angular_velocity", "must be at most 10000 rad/s");
    b.friction = r.friction("friction", b.friction);
    // Restitution above 1 gives energy at every bounce.
    b.restitution = r.number("restitution", b.restitution, 0.0);
    if (b.restitution > 1.0)
      r.fail("restitution", "must be in [0, 1] (got " + show_count(b.restitution) + ")");
    if (r.has("motion")) {
      if (b.mass > 0.0) r.fail("motion", "a kinematic body has mass 0");
      b.motion = parse_body_motion(r.object("motion"), b.pose);
    }
    if (r.has("attach")) {
      const auto att = r.objects("attach");
      for (size_t k = 0; k < att.size(); ++k) {
        const JsonReader& a = att[k];
        const size_t first = b.attachments.size();
        collision::BodyAttachment ba;
        ba.cloth = a.integer("cloth", 0, 0, static_cast<int>(scene.setup.cloths.size()) - 1);
        const cloth::ClothMesh& mesh = *scene.setup.cloths[ba.cloth].mesh;
        if (a.has("vertex") == a.has("grid")) a.fail("", "give either 'vertex' or 'grid'");
        if (a.has("vertex")) {
          const nlohmann::json& v = a.raw("vertex");
          if (!v.is_number_integer()) a.integer("vertex");           // the type error
          if (!JsonReader::in_range(v, 0, mesh.num_vertices() - 1))  // compared before narrowing
            a.fail("vertex", "vertex " + v.dump() + " is out of range [0, " +
                                 std::to_string(mesh.num_vertices()) + ")");
          ba.vertex = v.get<int>();
          b.attachments.push_back(ba);
        } else {
          // "grid": [iu, iv] (negative counts from the end) or [iu, "all"] / ["all", iv] for a whole row.
          const nlohmann::json& g = a.raw("grid");
          if (!g.is_array() || g.size() != 2) a.fail("grid", "expected [iu, iv]");
          const int nu = mesh.grid_nodes_u(), nv = mesh.grid_nodes_v();
          if (nu <= 0) a.fail("grid", "the cloth is not a grid");
          auto range = [&](const nlohmann::json& v, int n, const char* what) {
            std::vector<int> out;
            if (v.is_string() && v.get<std::string>() == "all") {
              for (int k2 = 0; k2 < n; ++k2) out.push_back(k2);
            } else if (v.is_number_integer()) {
              // Compared as a 64-bit value before narrowing: 2^32 + 1 is out of range, never 1.
              if (!JsonReader::in_range(v, -n, n - 1))
                a.fail("grid", std::string(what) + " " + v.dump() + " is outside the " + std::to_string(nu) +
                                   "x" + std::to_string(nv) + " grid (" + what + " in [" +
                                   std::to_string(-n) + ", " + std::to_string(n - 1) + "])");
              int k2 = static_cast<int>(v.get<long long>());
              if (k2 < 0) k2 += n;
              out.push_back(k2);
            } else {
              a.fail("grid", "expected an integer or \"all\"");
            }
            return out;
          };
          for (int iv : range(g[1], nv, "iv"))
            for (int iu : range(g[0], nu, "iu")) {
              ba.vertex = mesh.grid_index(iu, iv);
              b.attachments.push_back(ba);
            }
        }
        a.finish();
        for (size_t n = first; n < b.attachments.size(); ++n) {
          // A dynamic body holds its vertices at their start offsets as a rigid lever: a vertex beyond the
          // body's bounding sphere plus kAttachReach turns a light body into a long lever that the coupled
          // solve cannot keep finite, so the vertex must start on or near the body.
          if (b.mass > 0.0) {
            const cloth::ClothMesh& m = *scene.setup.cloths[b.attachments[n].cloth].mesh;
            const double d = (m.rest_positions()[b.attachments[n].vertex] - b.pose.translation()).norm();
            const double reach = bounding_radius(b.shape) + kAttachReach;
            if (d > reach)
              a.fail("", "attaches vertex " + std::to_string(b.attachments[n].vertex) + " of cloths[" +
                             std::to_string(b.attachments[n].cloth) + "], " + show_limit(d) +
                             " m from the centre of a dynamic body that reaches " + show_limit(reach) +
                             " m: place the body at its vertices");
          }
          // A pinned vertex is held by its pin already: attached too, the body and the pin pull it apart.
          const cloth::ClothSetup& c = scene.setup.cloths[b.attachments[n].cloth];
          std::vector<int>& pinned = pin_of[b.attachments[n].cloth];
          if (pinned.empty()) {
            pinned.assign(c.mesh->num_vertices(), -1);
            for (size_t p = c.pins.size(); p-- > 0;)
              if (c.pins[p].vertex >= 0 && c.pins[p].vertex < c.mesh->num_vertices())
                pinned[c.pins[p].vertex] = static_cast<int>(p);
          }
          const int p = pinned[b.attachments[n].vertex];
          if (p >= 0)
            a.fail("", "attaches vertex " + std::to_string(b.attachments[n].vertex) + " of cloths[" +
                           std::to_string(b.attachments[n].cloth) + "], which " +
                           (static_cast<size_t>(p) < c.pin_fields.size() ? c.pin_fields[p] : "a pin") +
                           " pins already: a vertex is pinned or attached, not both");
          const auto [it, added] =
              held.emplace(std::make_pair(b.attachments[n].cloth, b.attachments[n].vertex), a.path());
          if (!added)
            a.fail("", "attaches vertex " + std::to_string(b.attachments[n].vertex) + " of cloths[" +
                           std::to_string(b.attachments[n].cloth) + "], which " + it->second +
                           " attaches already: a vertex follows one body, once");
        }
      }
    }
    r.finish();
    scene.bodies.push_back(std::move(b));
  }
}

}  // namespace loom::scene
