#include "loom/collision/ColliderGeometry.h"

#include <cmath>
#include <cstdio>

extern "C" {
#include <libqhull_r/qhull_ra.h>
}

#include "FclShape.h"
#include "loom/cloth/Error.h"

namespace loom::collision {

namespace {

// The convex hull of the points with Qhull (Barber, Dobkin, Huhdanpaa 1996), triangulated ("Qt"), faces
// oriented outward; planes from the triangles' own normals (not Qhull's merged facet normals) so every hull
// vertex lies on or behind every plane up to round-off.
void build_hull(const std::vector<Vec3>& points, const std::string& where, ColliderGeometry& g) {
  if (points.size() < 4) throw Error("", where, "a convex collider needs at least 4 vertices");
  for (const Vec3& p : points)
    if (!p.allFinite()) throw Error("", where, "a vertex is not finite");
  std::vector<coordT> coords;
  for (const Vec3& p : points) coords.insert(coords.end(), {p.x(), p.y(), p.z()});
  qhT qh_qh;
  qhT* qh = &qh_qh;
  FILE* err = std::fopen("/dev/null", "w");
  qh_zero(qh, err);
  char flags[] = "qhull Qt";
  const int code =
      qh_new_qhull(qh, 3, static_cast<int>(points.size()), coords.data(), False, flags, nullptr, err);
  std::vector<int> used(points.size(), -1);
  if (code == 0) {
    facetT* facet;
    FORALLfacets {
      int idx[3], k = 0;
      vertexT *vertex, **vertexp;
      FOREACHvertex_(facet->vertices) {
        if (k < 3) idx[k] = qh_pointid(qh, vertex->point);
        ++k;
      }
      if (k != 3) continue;
      Tri t{idx[0], idx[1], idx[2]};
      const Vec3 n = (points[t[1]] - points[t[0]]).cross(points[t[2]] - points[t[0]]);
      const Vec3 qn(facet->normal[0], facet->normal[1], facet->normal[2]);
      if (n.dot(qn) < 0) std::swap(t[1], t[2]);
      for (int& v : t) {
        if (used[v] < 0) {
          used[v] = static_cast<int>(g.hull_vertices.size());
          g.hull_vertices.push_back(points[v]);
        }
        v = used[v];
      }
      g.hull_triangles.push_back(t);
    }
  }
  qh_freeqhull(qh, !qh_ALL);
  int curlong = 0, totlong = 0;
  qh_memfreeshort(qh, &curlong, &totlong);
  std::fclose(err);
  if (code != 0 || g.hull_triangles.size() < 4)
    throw Error("", where,
                "the convex hull of the vertices is degenerate (fewer than 4 non-coplanar points?)");
  for (const Tri& t : g.hull_triangles) {
    const Vec3& a = g.hull_vertices[t[0]];
    Vec3 n = (g.hull_vertices[t[1]] - a).cross(g.hull_vertices[t[2]] - a);
    const double len = n.norm();
    if (!(len > 0.0)) continue;
    n /= len;
    g.hull_planes.emplace_back(n.x(), n.y(), n.z(), n.dot(a));
  }
  // FCL's Convex: faces as (count, i0, i1, i2) triples.
  auto verts = std::make_shared<std::vector<fcl::Vector3d>>(g.hull_vertices.begin(), g.hull_vertices.end());
  auto faces = std::make_shared<std::vector<int>>();
  for (const Tri& t : g.hull_triangles) faces->insert(faces->end(), {3, t[0], t[1], t[2]});
  auto fcl_shape = std::make_shared<FclShape>();
  fcl_shape->geometry =
      std::make_shared<fcl::Convexd>(verts, static_cast<int>(g.hull_triangles.size()), faces);
  fcl_shape->geometry->computeLocalAABB();
  g.fcl = fcl_shape;
}

void build_mesh(const Shape& s, const std::string& where, ColliderGeometry& g) {
  if (s.vertices.empty() || s.triangles.empty())
    throw Error("", where, "a mesh collider needs vertices and triangles");
  const int n = static_cast<int>(s.vertices.size());
  for (const Vec3& p : s.vertices)
    if (!p.allFinite()) throw Error("", where, "a vertex is not finite");
  std::vector<fcl::Vector3d> pts(s.vertices.begin(), s.vertices.end());
  std::vector<fcl::Triangle> tris;
  for (size_t k = 0; k < s.triangles.size(); ++k) {
    const Tri& t = s.triangles[k];
    for (int v : t)
      if (v < 0 || v >= n)
        throw Error("", where,
                    "triangle " + std::to_string(k) + " has vertex " + std::to_string(v) +
                        " out of range [0, " + std::to_string(n) + ")");
    tris.emplace_back(t[0], t[1], t[2]);
  }
  auto model = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  model->beginModel(static_cast<int>(tris.size()), n);
  model->addSubModel(pts, tris);
  model->endModel();
  model->computeLocalAABB();
  auto fcl_shape = std::make_shared<FclShape>();
  fcl_shape->geometry = model;
  fcl_shape->is_mesh = true;
  g.fcl = fcl_shape;
}

}  // namespace

std::shared_ptr<const ColliderGeometry> build_collider_geometry(const Shape& shape,
                                                                const std::string& where) {
  if (shape.type != ShapeType::convex && shape.type != ShapeType::mesh) return nullptr;
  auto g = std::make_shared<ColliderGeometry>();
  if (shape.type == ShapeType::convex)
    build_hull(shape.vertices, where, *g);
  else
    build_mesh(shape, where, *g);
  const std::vector<Vec3>& pts = shape.type == ShapeType::convex ? g->hull_vertices : shape.vertices;
  g->local_lo = Vec3::Constant(HUGE_VAL);
  g->local_hi = Vec3::Constant(-HUGE_VAL);
  for (const Vec3& p : pts) g->local_lo = g->local_lo.cwiseMin(p), g->local_hi = g->local_hi.cwiseMax(p);
  return g;
}

void prepare_collider(Collider& c) {
  if (!c.geometry) c.geometry = build_collider_geometry(c.shape, c.name);
}

void local_bounds(const Shape& s, const ColliderGeometry* g, Vec3& lo, Vec3& hi) {
  switch (s.type) {
    case ShapeType::plane:
      lo = Vec3::Constant(-HUGE_VAL), hi = Vec3::Constant(HUGE_VAL);
      return;
    case ShapeType::sphere:
      lo = Vec3::Constant(-s.radius), hi = Vec3::Constant(s.radius);
      return;
    case ShapeType::capsule:
      hi = Vec3(s.radius, s.half_height + s.radius, s.radius), lo = -hi;
      return;
    case ShapeType::box:
      hi = s.half_extents, lo = -hi;
      return;
    case ShapeType::cylinder:
      hi = Vec3(s.radius, s.half_height, s.radius), lo = -hi;
      return;
    case ShapeType::convex:
    case ShapeType::mesh:
      if (g) {
        lo = g->local_lo, hi = g->local_hi;
        return;
      }
      lo = Vec3::Constant(HUGE_VAL), hi = Vec3::Constant(-HUGE_VAL);
      for (const Vec3& p : s.vertices) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
      return;
  }
}

}  // namespace loom::collision
