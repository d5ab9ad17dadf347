#include "loom/collision/ColliderDistance.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "FclShape.h"
#include "loom/collision/Distance.h"

namespace loom::collision {

namespace {

// Any unit vector perpendicular to... nothing: the fallback normal when the point sits exactly on a centre.
const Vec3 kUp(0.0, 1.0, 0.0);

double sphere_sd(double r, const Vec3& q, Vec3* n) {
  const double len = q.norm();
  if (n) *n = len > 0.0 ? Vec3(q / len) : kUp;
  return len - r;
}

// Box |x_i| <= e_i: outside, the distance to the clamped point; inside, minus the distance to the nearest
// face.
double box_sd(const Vec3& e, const Vec3& q, Vec3* n) {
  const Vec3 w = q.cwiseAbs() - e;
  const Vec3 sgn(q.x() < 0 ? -1.0 : 1.0, q.y() < 0 ? -1.0 : 1.0, q.z() < 0 ? -1.0 : 1.0);
  if ((w.array() > 0.0).any()) {
    const Vec3 out = w.cwiseMax(0.0);
    const double d = out.norm();
    if (n) *n = out.cwiseProduct(sgn) / d;
    return d;
  }
  int k = 0;
  w.maxCoeff(&k);
  if (n) *n = Vec3::Unit(k) * sgn[k];
  return w[k];
}

// Cylinder about y: radial excess and axial excess combined like a 2D box.
double cylinder_sd(double r, double hh, const Vec3& q, Vec3* n) {
  const double rho = std::hypot(q.x(), q.z());
  const Vec3 radial = rho > 0.0 ? Vec3(q.x() / rho, 0.0, q.z() / rho) : Vec3(1.0, 0.0, 0.0);
  const Vec3 axial(0.0, q.y() < 0 ? -1.0 : 1.0, 0.0);
  const double wr = rho - r, wy = std::abs(q.y()) - hh;
  if (wr > 0.0 || wy > 0.0) {
    const double a = std::max(wr, 0.0), b = std::max(wy, 0.0);
    const double d = std::hypot(a, b);
    if (n) *n = (a * radial + b * axial) / d;
    return d;
  }
  if (wr > wy) {
    if (n) *n = radial;
    return wr;
  }
  if (n) *n = axial;
  return wy;
}

double convex_sd(const ColliderGeometry& g, const Vec3& q, Vec3* n) {
  // Inside (or on) the hull: the largest plane distance, attained on that face.
  double best = -HUGE_VAL;
  int face = 0;
  for (size_t k = 0; k < g.hull_planes.size(); ++k) {
    const Eigen::Vector4d& pl = g.hull_planes[k];
    const double s = pl.head<3>().dot(q) - pl[3];
    if (s > best) best = s, face = static_cast<int>(k);
  }
  if (best <= 0.0) {
    if (n) *n = g.hull_planes[face].head<3>();
    return best;
  }
  // Outside. Near the hull (within 1% of its size) the exact closest point over the hull's triangles:
  // there FCL's GJK meets degenerate simplices and its Debian build asserts (libccd_extension::doSimplex2).
  // Farther away GJK through FCL/libccd (Gilbert, Johnson, Keerthi 1988).
  const double size = (g.local_hi - g.local_lo).norm();
  if (best > 0.01 * size) {
    static const auto point = std::make_shared<fcl::Sphered>(0.0);
    fcl::DistanceRequestd request(true);
    fcl::DistanceResultd result;
    fcl::Transform3d tq = fcl::Transform3d::Identity();
    tq.translation() = q;
    fcl::distance(g.fcl->geometry.get(), fcl::Transform3d::Identity(), point.get(), tq, request, result);
    const Vec3 dir = q - result.nearest_points[0];
    const double len = dir.norm();
    if (result.min_distance >= 0.0 && len > 0.0) {
      if (n) *n = dir / len;
      return len;  // |q - nearest| for the hull point GJK found
    }
  }
  double d2 = HUGE_VAL;
  Vec3 dir = g.hull_planes[face].head<3>();
  for (const Tri& t : g.hull_triangles) {
    const Vec3 &a = g.hull_vertices[t[0]], &b = g.hull_vertices[t[1]], &c = g.hull_vertices[t[2]];
    const auto cl = point_triangle_closest(q, a, b, c);
    if (cl.distance_squared < d2) {
      d2 = cl.distance_squared;
      dir = q - (cl.weights[0] * a + cl.weights[1] * b + cl.weights[2] * c);
    }
  }
  if (n) *n = dir.norm() > 0.0 ? Vec3(dir.normalized()) : Vec3(g.hull_planes[face].head<3>());
  return std::sqrt(d2);
}

// Lower bound (m) of the distance from q to anything inside an RSS (rectangle [0, l0] x [0, l1] in its
// frame's z = 0 plane, swept by a sphere of radius r): the distance to the rectangle minus r.
double rss_lower_bound(const fcl::RSSd& rss, const Vec3& q) {
  const Vec3 local = rss.axis.transpose() * (q - rss.To);
  const Vec3 on(std::clamp(local.x(), 0.0, rss.l[0]), std::clamp(local.y(), 0.0, rss.l[1]), 0.0);
  return (local - on).norm() - rss.r;
}

// Two-sided (unsigned) distance to a static triangle mesh: a nearest-triangle search over the mesh's own FCL
// OBBRSS tree (built once in ColliderGeometry, never refitted), branch and bound on the nodes' RSS distance
// lower bounds, nearer child first; exact point-triangle distance at the leaves (Distance.h). One traversal
// per query with no per-query set-up (fcl::distance fits an OBBRSS to the point probe on every call, which
// was a quarter of the funnel scene's run time). Warm start: the triangle this thread found last for this
// mesh (the body stage asks about one vertex several times in a row, then its neighbour), so the bound is
// tight from the first node. The answer does not depend on the warm start: nodes are pruned only when their
// bound exceeds the best distance (with a relative slack of 1e-12 for rounding), and among triangles at the
// same computed distance the lowest-numbered one wins.
double mesh_sd(const Shape& s, const ColliderGeometry& g, const Vec3& q, Vec3* n) {
  const auto& model = static_cast<const fcl::BVHModel<fcl::OBBRSSd>&>(*g.fcl->geometry);
  const int num_tris = static_cast<int>(s.triangles.size());
  thread_local const ColliderGeometry* hint_geometry = nullptr;
  thread_local int hint_tri = -1;
  double best = HUGE_VAL;  // m
  int best_tri = -1;
  Vec3 best_point = Vec3::Zero();
  auto visit = [&](int tri) {
    const Tri& t = s.triangles[tri];
    const Vec3 &a = s.vertices[t[0]], &b = s.vertices[t[1]], &c = s.vertices[t[2]];
    const auto cl = point_triangle_closest(q, a, b, c);
    const double d = std::sqrt(cl.distance_squared);
    if (d < best || (d == best && tri < best_tri))
      best = d, best_tri = tri, best_point = cl.weights[0] * a + cl.weights[1] * b + cl.weights[2] * c;
  };
  if (hint_geometry == &g && hint_tri >= 0 && hint_tri < num_tris) visit(hint_tri);
  auto pruned = [&](double bound) { return bound > best * (1.0 + 1e-12) + 1e-300; };
  struct Entry {
    int node;
    double bound;  // m
  };
  thread_local std::vector<Entry> stack;  // reused: no allocation per query
  stack.clear();
  stack.push_back({0, rss_lower_bound(model.getBV(0).bv.rss, q)});
  while (!stack.empty()) {
    const Entry e = stack.back();
    stack.pop_back();
    if (pruned(e.bound)) continue;
    const fcl::BVNode<fcl::OBBRSSd>& node = model.getBV(e.node);
    if (node.isLeaf()) {
      visit(node.primitiveId());
      continue;
    }
    const int l = node.leftChild(), r = node.rightChild();
    const double bl = rss_lower_bound(model.getBV(l).bv.rss, q),
                 br = rss_lower_bound(model.getBV(r).bv.rss, q);
    // Farther child below the nearer one, so the nearer is searched first and tightens `best`.
    const Entry near{bl <= br ? l : r, std::min(bl, br)}, far{bl <= br ? r : l, std::max(bl, br)};
    if (!pruned(far.bound)) stack.push_back(far);
    if (!pruned(near.bound)) stack.push_back(near);
  }
  hint_geometry = &g, hint_tri = best_tri;
  Vec3 dir = q - best_point;
  double d = best;
  if (best_tri >= 0 && !(d > 0.0)) {
    const Tri& t = s.triangles[best_tri];
    dir = (s.vertices[t[1]] - s.vertices[t[0]]).cross(s.vertices[t[2]] - s.vertices[t[0]]);
    d = 0.0;
  }
  if (n) *n = dir.norm() > 0.0 ? Vec3(dir.normalized()) : kUp;
  return d;
}

}  // namespace

double local_signed_distance(const Shape& s, const ColliderGeometry* g, const Vec3& q, Vec3* n) {
  switch (s.type) {
    case ShapeType::plane:
      if (n) *n = kUp;
      return q.y();
    case ShapeType::sphere:
      return sphere_sd(s.radius, q, n);
    case ShapeType::capsule:
      return sphere_sd(s.radius, q - Vec3(0.0, std::clamp(q.y(), -s.half_height, s.half_height), 0.0), n);
    case ShapeType::box:
      return box_sd(s.half_extents, q, n);
    case ShapeType::cylinder:
      return cylinder_sd(s.radius, s.half_height, q, n);
    case ShapeType::convex:
    case ShapeType::mesh: {
      std::shared_ptr<const ColliderGeometry> owned;
      if (!g) owned = build_collider_geometry(s), g = owned.get();
      return s.type == ShapeType::convex ? convex_sd(*g, q, n) : mesh_sd(s, *g, q, n);
    }
  }
  return HUGE_VAL;
}

double signed_distance(const Collider& c, const Transform& pose, const Vec3& p, Vec3* normal) {
  const Vec3 q = pose.inverse(Eigen::Isometry) * p;
  Vec3 nl;
  const double d = local_signed_distance(c.shape, c.geometry.get(), q, normal ? &nl : nullptr);
  if (normal) *normal = pose.linear() * nl;
  return d;
}

double segment_capsule_distance(const Collider& c, const Transform& pose, const Vec3& a, const Vec3& b,
                                double* s, Vec3* normal) {
  const Vec3 p0 = pose * Vec3(0.0, -c.shape.half_height, 0.0),
             p1 = pose * Vec3(0.0, c.shape.half_height, 0.0);
  const SegmentSegmentClosest cl = segment_segment_closest(a, b, p0, p1);
  const Vec3 on_edge = a + cl.s * (b - a), on_axis = p0 + cl.t * (p1 - p0);
  const Vec3 dir = on_edge - on_axis;
  const double len = dir.norm();
  if (s) *s = cl.s;
  if (normal) {
    if (len > 0.0) {
      *normal = dir / len;
    } else {
      // The edge crosses the axis: any direction perpendicular to both.
      Vec3 perp = (b - a).cross(p1 - p0);
      if (!(perp.norm() > 0.0)) perp = pose.linear() * Vec3(1.0, 0.0, 0.0);
      *normal = perp.normalized();
    }
  }
  return len - c.shape.radius;
}

namespace {

// Whether the segment A + t (B - A), t in [0, 1], meets the box |q_i| <= e_i (box-local coordinates; slab
// clipping).
bool segment_meets_box(const Vec3& A, const Vec3& B, const Vec3& e) {
  double t0 = 0.0, t1 = 1.0;
  const Vec3 D = B - A;
  for (int i = 0; i < 3; ++i) {
    if (D[i] == 0.0) {
      if (std::abs(A[i]) > e[i]) return false;
      continue;
    }
    double ta = (-e[i] - A[i]) / D[i], tb = (e[i] - A[i]) / D[i];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta), t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

}  // namespace

double segment_box_edges_distance(const Collider& c, const Transform& pose, const Vec3& a, const Vec3& b,
                                  double* s, Vec3* normal, const SegmentPast* past) {
  const Vec3& e = c.shape.half_extents;
  const Transform to_local = pose.inverse(Eigen::Isometry);
  const Vec3 A = to_local * a, B = to_local * b, D = B - A;
  if (segment_meets_box(A, B, e)) {
    // Separating-axis test of a segment against a box (Ericson 2005, Sec. 5.2.1 and 4.4): the way out is
    // along a face normal or along D x (a box axis); on a face normal the deepest point of the segment is an
    // end, on D x axis_i it is the segment's point closest to the box edge parallel to axis_i on that side.
    // With the segment's past, only directions it was separated along then are taken (the side it came
    // from: a cloth edge pushed against a wall that stands on the floor leaves sideways, not down through
    // the floor), the shortest of them; if none was, the shortest of all.
    Vec3 A0 = A, B0 = B;
    if (past) {
      const Transform past_local = past->pose.inverse(Eigen::Isometry);
      A0 = past_local * past->a, B0 = past_local * past->b;
    }
    double best = HUGE_VAL, best_any = HUGE_VAL;
    Vec3 dir_best = Vec3::UnitY(), dir_any = Vec3::UnitY();
    int k_best = -1, k_any = -1;
    for (int k = 0; k < 6; ++k) {
      Vec3 L = Vec3::Zero();
      if (k < 3) {
        L[k] = 1.0;
      } else {
        Vec3 axis = Vec3::Zero();
        axis[k - 3] = 1.0;
        L = D.cross(axis);
        const double len = L.norm();
        if (!(len > 1e-12 * D.norm())) continue;
        L /= len;
      }
      const double r = e.dot(L.cwiseAbs());
      for (const double sign : {1.0, -1.0}) {
        const Vec3 dir = sign * L;
        const double push = r - std::min(A.dot(dir), B.dot(dir));
        if (push < best_any) best_any = push, dir_any = dir, k_any = k;
        const bool came_from = past && std::min(A0.dot(dir), B0.dot(dir)) - r >= 0.0;
        if (came_from && push < best) best = push, dir_best = dir, k_best = k;
      }
    }
    if (k_best < 0) best = best_any, dir_best = dir_any, k_best = k_any;
    double sp = 0.0;
    if (k_best < 3) {
      sp = A.dot(dir_best) <= B.dot(dir_best) ? 0.0 : 1.0;  // the end deepest behind the face
    } else {
      // The box edge parallel to axis k-3 that is farthest along dir.
      const int ax = k_best - 3;
      Vec3 lo, hi;
      for (int j = 0; j < 3; ++j) lo[j] = hi[j] = dir_best[j] >= 0.0 ? e[j] : -e[j];
      lo[ax] = -e[ax], hi[ax] = e[ax];
      sp = segment_segment_closest(A, B, lo, hi).s;
    }
    // An end beyond the box's face planes but outside the box is no vertex contact: the whole segment
    // moves (its midpoint's correction, with equal inverse masses a translation).
    if (sp == 0.0 || sp == 1.0) {
      const Vec3& end = sp == 0.0 ? A : B;
      if ((end.cwiseAbs() - e).maxCoeff() > 0.0) sp = 0.5;
    }
    if (s) *s = sp;
    if (normal) *normal = pose.linear() * dir_best;
    return -best;
  }
  // Outside: the distance to the nearest of the 12 edges, away from it.
  double best = HUGE_VAL;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (int corner = 0; corner < 4; ++corner) {
      Vec3 lo = Vec3::Zero();
      lo[u] = (corner & 1) ? e[u] : -e[u];
      lo[v] = (corner & 2) ? e[v] : -e[v];
      Vec3 hi = lo;
      lo[axis] = -e[axis];
      hi[axis] = e[axis];
      const SegmentSegmentClosest cl = segment_segment_closest(A, B, lo, hi);
      const double d = std::sqrt(cl.distance_squared);
      if (!(d < best)) continue;
      best = d;
      const Vec3 dir = A + cl.s * D - (lo + cl.t * (hi - lo));
      // A segment touching the edge: the outward bisector of the edge's two faces.
      Vec3 bis = Vec3::Zero();
      bis[u] = lo[u] > 0 ? 1.0 : -1.0;
      bis[v] = lo[v] > 0 ? 1.0 : -1.0;
      if (s) *s = cl.s;
      if (normal) *normal = pose.linear() * (d > 0.0 ? Vec3(dir / d) : Vec3(bis.normalized()));
    }
  }
  return best;
}

}  // namespace loom::collision
