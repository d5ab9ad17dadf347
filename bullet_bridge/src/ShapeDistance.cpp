#include "ShapeDistance.h"

#include <LinearMath/btConvexHullComputer.h>

#include <algorithm>
#include <cmath>

#include "loom/collision/Distance.h"

namespace loom::bullet {

HullPlanes hull_planes(const std::vector<Vec3>& points) {
  HullPlanes out;
  if (points.size() < 4) return out;
  std::vector<double> coords;
  coords.reserve(points.size() * 3);
  for (const Vec3& p : points) coords.insert(coords.end(), {p.x(), p.y(), p.z()});
  btConvexHullComputer hull;
  hull.compute(coords.data(), 3 * static_cast<int>(sizeof(double)), static_cast<int>(points.size()), 0, 0);
  for (int f = 0; f < hull.faces.size(); ++f) {
    // Walk the face's edges: vertices in counter-clockwise order seen from outside.
    std::vector<Vec3> poly;
    const btConvexHullComputer::Edge* first = &hull.edges[hull.faces[f]];
    const btConvexHullComputer::Edge* e = first;
    do {
      const btVector3& v = hull.vertices[e->getSourceVertex()];
      poly.emplace_back(v.x(), v.y(), v.z());
      e = e->getNextEdgeOfFace();
    } while (e != first && poly.size() < 1000);
    if (poly.size() < 3) continue;
    // Newell's normal of the polygon.
    Vec3 n = Vec3::Zero();
    for (size_t i = 0; i < poly.size(); ++i) n += poly[i].cross(poly[(i + 1) % poly.size()]);
    if (n.norm() == 0.0) continue;
    n.normalize();
    out.normals.push_back(n);
    out.offsets.push_back(n.dot(poly[0]));
  }
  // Orientation check: the centroid must be inside (n·c < d); flip otherwise.
  Vec3 c = Vec3::Zero();
  for (const Vec3& p : points) c += p;
  c /= static_cast<double>(points.size());
  for (size_t i = 0; i < out.normals.size(); ++i)
    if (out.normals[i].dot(c) > out.offsets[i])
      out.normals[i] = -out.normals[i], out.offsets[i] = -out.offsets[i];
  return out;
}

namespace {

// Local-frame signed distance and outward normal.
double local_distance(const collision::Shape& s, const HullPlanes* hull, const Vec3& q, Vec3& n) {
  using collision::ShapeType;
  switch (s.type) {
    case ShapeType::plane:
      n = Vec3::UnitY();
      return q.y();
    case ShapeType::sphere: {
      const double r = q.norm();
      n = r > 0.0 ? Vec3(q / r) : Vec3(Vec3::UnitY());
      return r - s.radius;
    }
    case ShapeType::capsule: {
      const Vec3 c(0.0, std::clamp(q.y(), -s.half_height, s.half_height), 0.0);
      const Vec3 d = q - c;
      const double r = d.norm();
      n = r > 0.0 ? Vec3(d / r) : Vec3(Vec3::UnitX());
      return r - s.radius;
    }
    case ShapeType::box: {
      const Vec3 d = q.cwiseAbs() - s.half_extents;
      if ((d.array() > 0.0).any()) {
        const Vec3 o = d.cwiseMax(0.0);
        const double r = o.norm();
        n = Vec3(q.x() < 0 ? -o.x() : o.x(), q.y() < 0 ? -o.y() : o.y(), q.z() < 0 ? -o.z() : o.z()) / r;
        return r;
      }
      int k = 0;
      d.maxCoeff(&k);
      n = Vec3::Zero();
      n[k] = q[k] < 0 ? -1.0 : 1.0;
      return d[k];
    }
    case ShapeType::cylinder: {
      const double rr = std::hypot(q.x(), q.z());
      const Vec3 radial = rr > 0.0 ? Vec3(q.x() / rr, 0.0, q.z() / rr) : Vec3(Vec3::UnitX());
      const Vec3 axial(0.0, q.y() < 0 ? -1.0 : 1.0, 0.0);
      const double dr = rr - s.radius, dy = std::abs(q.y()) - s.half_height;
      if (dr > 0.0 || dy > 0.0) {
        const double a = std::max(dr, 0.0), b = std::max(dy, 0.0);
        const double r = std::hypot(a, b);
        n = (a * radial + b * axial) / r;
        return r;
      }
      n = dr > dy ? radial : axial;
      return std::max(dr, dy);
    }
    case ShapeType::convex: {
      double best = -HUGE_VAL;
      n = Vec3::UnitY();
      if (!hull) return HUGE_VAL;
      for (size_t i = 0; i < hull->normals.size(); ++i) {
        const double d = hull->normals[i].dot(q) - hull->offsets[i];
        if (d > best) best = d, n = hull->normals[i];
      }
      return hull->normals.empty() ? HUGE_VAL : best;
    }
    case ShapeType::mesh: {
      double best = HUGE_VAL;
      n = Vec3::UnitY();
      for (const cloth::Tri& t : s.triangles) {
        const Vec3 &a = s.vertices[t[0]], &b = s.vertices[t[1]], &c = s.vertices[t[2]];
        // Cheap reject: farther than the best from the triangle's bounding sphere.
        const collision::PointTriangleClosest pc = collision::point_triangle_closest(q, a, b, c);
        if (pc.distance_squared < best * best || best == HUGE_VAL) {
          const double d = std::sqrt(pc.distance_squared);
          if (d >= best) continue;
          best = d;
          const Vec3 cp = pc.weights[0] * a + pc.weights[1] * b + pc.weights[2] * c;
          if (d > 0.0) {
            n = (q - cp) / d;
          } else {
            n = (b - a).cross(c - a).normalized();
          }
        }
      }
      return best;
    }
  }
  return HUGE_VAL;
}

}  // namespace

double shape_signed_distance(const collision::Shape& shape, const HullPlanes* hull, const Transform& pose,
                             const Vec3& p, Vec3* normal) {
  Vec3 n;
  const double d = local_distance(shape, hull, pose.inverse(Eigen::Isometry) * p, n);
  if (normal) *normal = pose.linear() * n;
  return d;
}

}  // namespace loom::bullet
