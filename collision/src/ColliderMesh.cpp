#include "loom/collision/ColliderMesh.h"

#include <algorithm>
#include <cmath>

#include "loom/collision/ColliderGeometry.h"

namespace loom::collision {

namespace {

constexpr double kPi = 3.14159265358979323846;

// A surface of revolution about y: `profile` gives (radius, y, normal radial part, normal y part) per ring,
// bottom to top; rings of zero radius (poles) are single points repeated around.
struct Ring {
  double r, y, nr, ny;
};

void add_revolution(ColliderMesh& m, const std::vector<Ring>& rings, int segments) {
  const int base = static_cast<int>(m.vertices.size());
  const int cols = segments + 1;  // the seam is duplicated so every column has its own vertex
  for (const Ring& ring : rings)
    for (int j = 0; j <= segments; ++j) {
      const double a = 2.0 * kPi * (j % segments) / segments, c = std::cos(a), s = std::sin(a);
      m.vertices.emplace_back(ring.r * c, ring.y, ring.r * s);
      m.normals.push_back(Vec3(ring.nr * c, ring.ny, ring.nr * s).normalized());
    }
  for (size_t i = 0; i + 1 < rings.size(); ++i)
    for (int j = 0; j < segments; ++j) {
      const int a = base + static_cast<int>(i) * cols + j, b = a + 1, c = a + cols, d = c + 1;
      // Outward: going up (c) then around (b) is counter-clockwise seen from outside for x = cos, z = sin.
      if (rings[i].r > 0.0) m.triangles.push_back({a, c, b});
      if (rings[i + 1].r > 0.0) m.triangles.push_back({b, c, d});
    }
}

// A flat face: corners counter-clockwise seen from outside, normal n.
void add_polygon(ColliderMesh& m, const std::vector<Vec3>& corners, const Vec3& n) {
  const int base = static_cast<int>(m.vertices.size());
  for (const Vec3& p : corners) {
    m.vertices.push_back(p);
    m.normals.push_back(n);
  }
  for (size_t k = 1; k + 1 < corners.size(); ++k)
    m.triangles.push_back({base, base + static_cast<int>(k), base + static_cast<int>(k) + 1});
}

// Rings of a hemisphere cap of radius r centred at height yc, from its pole (dir = -1 bottom, +1 top) to
// its equator, or the reverse.
std::vector<Ring> hemisphere(double r, double yc, int dir, int steps, bool from_pole) {
  std::vector<Ring> rings;
  for (int k = 0; k <= steps; ++k) {
    const int i = from_pole ? k : steps - k;
    const double phi = 0.5 * kPi * i / steps;  // 0 at the pole
    const double nr = std::sin(phi), ny = dir * std::cos(phi);
    rings.push_back({i == 0 ? 0.0 : r * nr, yc + r * ny, nr, ny});
  }
  return rings;
}

}  // namespace

ColliderMesh tessellate(const Shape& s, const ColliderGeometry* geometry,
                        const TessellationSettings& settings) {
  ColliderMesh m;
  const int seg = std::max(3, settings.segments), lat = std::max(2, seg / 4);
  switch (s.type) {
    case ShapeType::plane: {
      const double h = settings.plane_half_size;
      add_polygon(m, {Vec3(-h, 0, -h), Vec3(-h, 0, h), Vec3(h, 0, h), Vec3(h, 0, -h)}, Vec3(0, 1, 0));
      break;
    }
    case ShapeType::sphere: {
      std::vector<Ring> rings = hemisphere(s.radius, 0.0, -1, lat, true);
      const std::vector<Ring> top = hemisphere(s.radius, 0.0, 1, lat, false);
      rings.insert(rings.end(), top.begin() + 1, top.end());  // the equator once
      add_revolution(m, rings, seg);
      break;
    }
    case ShapeType::capsule: {
      std::vector<Ring> rings = hemisphere(s.radius, -s.half_height, -1, lat, true);
      const std::vector<Ring> top = hemisphere(s.radius, s.half_height, 1, lat, false);
      rings.insert(rings.end(), top.begin(), top.end());  // the tube joins the two equators
      add_revolution(m, rings, seg);
      break;
    }
    case ShapeType::cylinder: {
      const double r = s.radius, h = s.half_height;
      add_revolution(m, {{r, -h, 1, 0}, {r, h, 1, 0}}, seg);
      add_revolution(m, {{0, -h, 0, -1}, {r, -h, 0, -1}}, seg);  // bottom cap, from the centre out
      add_revolution(m, {{r, h, 0, 1}, {0, h, 0, 1}}, seg);      // top cap, from the rim in
      break;
    }
    case ShapeType::box: {
      const Vec3& e = s.half_extents;
      for (int axis = 0; axis < 3; ++axis)
        for (int sign : {-1, 1}) {
          const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // (u, v, axis) right-handed
          Vec3 n = Vec3::Zero();
          n[axis] = sign;
          std::vector<Vec3> c(4, Vec3::Zero());
          const double su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
          for (int k = 0; k < 4; ++k) {
            c[k][axis] = sign * e[axis];
            c[k][u] = su[k] * e[u];
            c[k][v] = sv[k] * e[v];
          }
          if (sign < 0) std::reverse(c.begin(), c.end());
          add_polygon(m, c, n);
        }
      break;
    }
    case ShapeType::convex: {
      std::shared_ptr<const ColliderGeometry> built;
      if (!geometry) {
        built = build_collider_geometry(s, "convex collider");
        geometry = built.get();
      }
      for (const Tri& t : geometry->hull_triangles) {
        const Vec3 &a = geometry->hull_vertices[t[0]], &b = geometry->hull_vertices[t[1]],
                   &c = geometry->hull_vertices[t[2]];
        const Vec3 n = (b - a).cross(c - a);
        if (n.norm() > 0.0) add_polygon(m, {a, b, c}, n.normalized());
      }
      break;
    }
    case ShapeType::mesh: {
      // The mesh's own triangles with area-weighted vertex normals (two-sided in contact and drawing).
      m.vertices = s.vertices;
      m.triangles = s.triangles;
      m.normals.assign(s.vertices.size(), Vec3::Zero());
      for (const Tri& t : s.triangles) {
        const Vec3 n = (s.vertices[t[1]] - s.vertices[t[0]]).cross(s.vertices[t[2]] - s.vertices[t[0]]);
        for (int k = 0; k < 3; ++k) m.normals[t[k]] += n;
      }
      for (Vec3& n : m.normals) n = n.norm() > 0.0 ? Vec3(n.normalized()) : Vec3(0, 1, 0);
      break;
    }
  }
  return m;
}

ColliderMesh transformed(const ColliderMesh& local, const Transform& pose) {
  ColliderMesh m;
  m.triangles = local.triangles;
  m.vertices.reserve(local.vertices.size());
  m.normals.reserve(local.normals.size());
  for (const Vec3& p : local.vertices) m.vertices.push_back(pose * p);
  for (const Vec3& n : local.normals) m.normals.push_back(pose.linear() * n);
  return m;
}

}  // namespace loom::collision
