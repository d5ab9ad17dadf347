#include "ContactStage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

namespace loom::bullet {

namespace {

// Radius (m) of a ball around the local origin that holds the shape; infinity for planes.
double bounding_radius(const collision::Shape& s) {
  using collision::ShapeType;
  switch (s.type) {
    case ShapeType::plane:
      return HUGE_VAL;
    case ShapeType::sphere:
      return s.radius;
    case ShapeType::capsule:
      return s.radius + s.half_height;
    case ShapeType::box:
      return s.half_extents.norm();
    case ShapeType::cylinder:
      return std::hypot(s.radius, s.half_height);
    case ShapeType::convex:
    case ShapeType::mesh: {
      double r = 0.0;
      for (const Vec3& v : s.vertices) r = std::max(r, v.norm());
      return r;
    }
  }
  return HUGE_VAL;
}

// The axis-aligned box (lo, hi) of a cloth's vertices.
std::pair<Vec3, Vec3> cloth_box(const cloth::ClothState& s) {
  Vec3 lo = Vec3::Constant(HUGE_VAL), hi = Vec3::Constant(-HUGE_VAL);
  for (const Vec3& x : s.x) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
  return {lo, hi};
}

// A lower bound (m) of the collider's signed distance over the box (every cloth point, vertex or on an
// edge, lies in it): a plane's least value over the box's corners; otherwise the distance from the
// shape's bounding ball at curr.
double bound_distance(const collision::Collider& c, const std::pair<Vec3, Vec3>& box) {
  const Vec3 &lo = box.first, &hi = box.second;
  if (!(lo.array() <= hi.array()).all()) return HUGE_VAL;  // no vertices
  if (c.shape.type == collision::ShapeType::plane) {
    const Vec3 n = c.curr.linear().col(1);  // the plane's local +y
    const Vec3 corner(n.x() < 0 ? hi.x() : lo.x(), n.y() < 0 ? hi.y() : lo.y(), n.z() < 0 ? hi.z() : lo.z());
    return n.dot(corner - c.curr.translation());
  }
  const Vec3 p = c.curr.translation();
  return (p - p.cwiseMax(lo).cwiseMin(hi)).norm() - bounding_radius(c.shape);
}

}  // namespace

const HullPlanes* ContactStage::hull_for(const collision::Collider& c) {
  if (c.shape.type != collision::ShapeType::convex) return nullptr;
  const std::string key = c.name + "#" + std::to_string(c.shape.vertices.size());
  auto it = hulls_.find(key);
  if (it == hulls_.end()) it = hulls_.emplace(key, hull_planes(c.shape.vertices)).first;
  return &it->second;
}

void ContactStage::run(cloth::StageContext& ctx) {
  last_penetration_ = 0.0;
  if (!colliders_) return;
  for (collision::Collider& col : *colliders_) {
    const HullPlanes* hull = hull_for(col);
    const double reach = bounding_radius(col.shape) + thickness_;
    const Vec3 centre = col.curr.translation();
    // Maps a point at curr to where the same body point was at prev: its velocity is the difference / h.
    const Transform back = col.prev * col.curr.inverse(Eigen::Isometry);
    const double mu = col.friction;
    for (auto& cl : ctx.cloths) {
      cloth::ClothState& s = cl->state();
      if (!(bound_distance(col, cloth_box(s)) < thickness_)) continue;  // no vertex or edge within reach
      for (int i = 0; i < s.size(); ++i) {
        if (s.inv_mass[i] == 0.0) continue;  // pinned / attached: prescribed
        Vec3& x = s.x[i];
        if ((x - centre).squaredNorm() > reach * reach) continue;
        Vec3 n;
        const double phi = shape_signed_distance(col.shape, hull, col.curr, x, &n);
        if (!(phi < thickness_)) continue;
        ++contacts_;
        last_penetration_ = std::max(last_penetration_, -phi);
        x += (thickness_ - phi) * n;
        const Vec3 vb = (x - back * x) / ctx.h;  // m/s, the body point's velocity
        Vec3& v = s.v[i];
        const Vec3 rel = v - vb;
        const double vn = rel.dot(n);
        if (vn >= 0.0) continue;  // separating: position fix only
        const Vec3 vt = rel - vn * n;
        const double vt_norm = vt.norm();
        // Coulomb: the tangential speed drops by at most mu |vn| (kinetic friction impulse <= mu normal).
        const double keep = vt_norm > 0.0 ? std::max(0.0, 1.0 - mu * (-vn) / vt_norm) : 0.0;
        const Vec3 v_new = vb + keep * vt;
        const Vec3 impulse = s.mass[i] * (v_new - v);  // N s given to the cloth
        v = v_new;
        col.reaction_impulse -= impulse;
        col.reaction_angular_impulse -= (x - centre).cross(impulse);
      }
      if (edges_ && col.shape.type != collision::ShapeType::mesh)
        edge_contacts(col, hull, reach, back, ctx.h, s, cl->mesh());
    }
  }
}

// Edge pass (convex shapes): a collider's edge or corner can slice between two cloth vertices that are
// both outside it (a box's bottom edge through the cloth under it). The signed distance of a convex shape
// is a convex function, so along a cloth edge x(t) = (1 - t) x_i + t x_j it has one minimum, found by a
// golden-section search. If that deepest point is inside the contact offset at an interior t, the edge is
// pushed out and its approach velocity removed there, the correction shared by the two ends with weights
// (1 - t) w_i and t w_j (w: inverse masses; the point x(t) moves by the full amount), and minus the impulse
// goes to the collider as for vertices.
void ContactStage::edge_contacts(collision::Collider& col, const HullPlanes* hull, double reach,
                                 const Transform& back, double h, cloth::ClothState& s,
                                 const cloth::ClothMesh& mesh) {
  const Vec3 centre = col.curr.translation();
  const double mu = col.friction;
  const double reach2 = reach * reach;
  auto phi_at = [&](const Vec3& p, Vec3* n) {
    return shape_signed_distance(col.shape, hull, col.curr, p, n);
  };
  for (const cloth::Edge& e : mesh.edges()) {
    const double wi = s.inv_mass[e.i], wj = s.inv_mass[e.j];
    if (wi == 0.0 || wj == 0.0) continue;  // a held end: the free end's vertex contact is enough
    Vec3 &xi = s.x[e.i], &xj = s.x[e.j];
    // Cull: the edge's nearest point to the shape's bounding ball centre must be within reach.
    const Vec3 d = xj - xi;
    const double dd = d.squaredNorm();
    const double tc = dd > 0.0 ? std::clamp((centre - xi).dot(d) / dd, 0.0, 1.0) : 0.0;
    if ((xi + tc * d - centre).squaredNorm() > reach2) continue;
    // Cull by the ends (exact for a convex phi, whose returned normal is a subgradient): phi(x(t)) >=
    // phi_i + t n_i·d, so n_i·d >= 0 puts the minimum at t = 0; likewise n_j·d <= 0 puts it at t = 1. A
    // plane (phi affine) or a large box under the cloth (both ends over one face) never reaches the search.
    // phi is 1-Lipschitz, so phi(x(t)) >= (phi_i + phi_j - |d|) / 2: an edge that far away is skipped too.
    Vec3 ni, nj;
    const double phi_i = phi_at(xi, &ni), phi_j = phi_at(xj, &nj);
    if (ni.dot(d) >= 0.0 || nj.dot(d) <= 0.0) continue;
    if (0.5 * (phi_i + phi_j - std::sqrt(dd)) >= thickness_) continue;
    // Golden-section search of the convex phi(t) on [0, 1].
    constexpr double g = 0.6180339887498949;
    double a = 0.0, b = 1.0;
    double t1 = b - g * (b - a), t2 = a + g * (b - a);
    double f1 = phi_at(xi + t1 * d, nullptr), f2 = phi_at(xi + t2 * d, nullptr);
    for (int it = 0; it < 24; ++it) {
      if (f1 < f2) {
        b = t2, t2 = t1, f2 = f1;
        t1 = b - g * (b - a);
        f1 = phi_at(xi + t1 * d, nullptr);
      } else {
        a = t1, t1 = t2, f1 = f2;
        t2 = a + g * (b - a);
        f2 = phi_at(xi + t2 * d, nullptr);
      }
    }
    const double t = 0.5 * (a + b);
    if (t < 0.02 || t > 0.98) continue;  // at an end: the vertex pass handled it
    Vec3 n;
    const Vec3 p = xi + t * d;
    const double phi = phi_at(p, &n);
    if (!(phi < thickness_)) continue;
    // Only a true interior minimum: deeper than both ends (otherwise the vertex pass has it).
    if (!(phi < std::min(phi_i, phi_j) - 1e-9)) continue;
    // Push across the edge, not along it: the normal's part perpendicular to the cloth edge. At a smooth
    // surface the interior minimum already has n ⟂ d; at a box edge the nearest face's normal would slide
    // the cloth edge off the corner, while the perpendicular part is the edge-edge normal (it wraps the
    // cloth round the corner). The push grows by 1 / (n·n') so x(t) leaves by the same depth.
    const Vec3 dh = d / std::sqrt(dd);
    Vec3 np = n - n.dot(dh) * dh;
    const double np_norm = np.norm();
    if (!(np_norm > 0.3)) continue;
    np /= np_norm;
    const double depth = (thickness_ - phi) / np_norm;
    n = np;
    const double ai = (1.0 - t) * wi, aj = t * wj;
    const double denom =
        (1.0 - t) * ai + t * aj;  // m/s of x(t) per N s applied at x(t), i.e. 1 / effective mass
    if (!(denom > 0.0)) continue;
    ++edge_contacts_;
    last_penetration_ = std::max(last_penetration_, -phi);
    const double lambda = depth / denom;
    xi += ai * lambda * n;
    xj += aj * lambda * n;
    const Vec3 q = xi + t * (xj - xi);   // the contact point after the push
    const Vec3 vb = (q - back * q) / h;  // m/s, the body point's velocity
    Vec3 &vi = s.v[e.i], &vj = s.v[e.j];
    const Vec3 rel = (1.0 - t) * vi + t * vj - vb;
    const double vn = rel.dot(n);
    if (vn >= 0.0) continue;
    const Vec3 vt = rel - vn * n;
    const double vt_norm = vt.norm();
    const double keep = vt_norm > 0.0 ? std::max(0.0, 1.0 - mu * (-vn) / vt_norm) : 0.0;
    const Vec3 dv = (vb + keep * vt) - (rel + vb);  // wanted change of x(t)'s velocity
    const Vec3 impulse = dv / denom;                // N s given to the cloth at x(t)
    vi += ai * impulse;
    vj += aj * impulse;
    col.reaction_impulse -= impulse;
    col.reaction_angular_impulse -= (q - centre).cross(impulse);
  }
}

}  // namespace loom::bullet
