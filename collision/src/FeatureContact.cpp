#include "loom/collision/FeatureContact.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include "GridCell.h"
#include "loom/cloth/Error.h"
#include "loom/collision/ColliderDistance.h"
#include "loom/collision/ColliderGeometry.h"
#include "loom/collision/SweptCollider.h"

namespace loom::collision {

ColliderFeatures collider_features(const Collider& c) {
  ColliderFeatures f;
  const Shape& s = c.shape;
  auto add = [&f](const Vec3& a, const Vec3& b) {
    f.a.push_back(a);
    f.b.push_back(b);
  };
  switch (s.type) {
    case ShapeType::plane:
    case ShapeType::mesh:
      break;
    case ShapeType::sphere:
      f.radius = s.radius;
      add(Vec3::Zero(), Vec3::Zero());
      break;
    case ShapeType::capsule:
      f.radius = s.radius;
      add(Vec3(0, -s.half_height, 0), Vec3(0, s.half_height, 0));
      break;
    case ShapeType::box: {
      const Vec3& e = s.half_extents;
      for (int axis = 0; axis < 3; ++axis) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        for (int su = -1; su <= 1; su += 2)
          for (int sv = -1; sv <= 1; sv += 2) {
            Vec3 a = Vec3::Zero();
            a[u] = su * e[u];
            a[v] = sv * e[v];
            Vec3 b = a;
            a[axis] = -e[axis];
            b[axis] = e[axis];
            add(a, b);
          }
      }
      break;
    }
    case ShapeType::cylinder: {
      constexpr int kSides = 12;
      for (int k = 0; k < kSides; ++k) {
        const double t0 = 2.0 * M_PI * k / kSides, t1 = 2.0 * M_PI * (k + 1) / kSides;
        const Vec3 r0(s.radius * std::cos(t0), 0, s.radius * std::sin(t0));
        const Vec3 r1(s.radius * std::cos(t1), 0, s.radius * std::sin(t1));
        const Vec3 up(0, s.half_height, 0);
        add(r0 - up, r1 - up);
        add(r0 + up, r1 + up);
        add(r0 - up, r0 + up);
      }
      break;
    }
    case ShapeType::convex: {
      std::shared_ptr<const ColliderGeometry> g =
          c.geometry ? c.geometry : build_collider_geometry(s, c.name);
      std::vector<std::pair<int, int>> edges;
      for (const Tri& t : g->hull_triangles)
        for (int e = 0; e < 3; ++e)
          edges.emplace_back(std::min(t[e], t[(e + 1) % 3]), std::max(t[e], t[(e + 1) % 3]));
      std::sort(edges.begin(), edges.end());
      edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
      for (const auto& [i, j] : edges) add(g->hull_vertices[i], g->hull_vertices[j]);
      break;
    }
  }
  return f;
}

// A uniform grid over one cloth's vertices and triangle centroids (counting sort into cells).
struct FeatureContactStage::Grid {
  Vec3 lo = Vec3::Zero();
  double cell = 1.0;  // m
  int nx = 1, ny = 1, nz = 1;
  std::vector<int> vert_start, verts, tri_start, tris;
  double tri_reach = 0.0;  // m, largest centroid-to-corner distance

  int clamp_index(double v, int n) const { return clamped_cell(std::floor(v / cell), 0, n - 1); }
  int cell_of(const Vec3& p) const {
    const Vec3 q = p - lo;
    return (clamp_index(q.z(), nz) * ny + clamp_index(q.y(), ny)) * nx + clamp_index(q.x(), nx);
  }
  static void fill(const std::vector<int>& cell_of_item, int cells, std::vector<int>& start,
                   std::vector<int>& items) {
    start.assign(cells + 1, 0);
    for (int c : cell_of_item) ++start[c + 1];
    for (int c = 0; c < cells; ++c) start[c + 1] += start[c];
    items.resize(cell_of_item.size());
    std::vector<int> next(start.begin(), start.end() - 1);
    for (size_t k = 0; k < cell_of_item.size(); ++k) items[next[cell_of_item[k]]++] = static_cast<int>(k);
  }
  void build(const cloth::ClothState& s, const cloth::ClothMesh& mesh) {
    Vec3 hi = Vec3::Constant(-HUGE_VAL);
    lo = Vec3::Constant(HUGE_VAL);
    for (const Vec3& x : s.x) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
    double edge = 0.0;
    for (const cloth::Edge& e : mesh.edges()) edge += (s.x[e.j] - s.x[e.i]).norm();
    edge = mesh.edges().empty() ? 0.05 : edge / mesh.edges().size();
    cell = std::max(2.0 * edge, 1e-3);
    const Vec3 ext = (hi - lo).cwiseMax(Vec3::Zero());
    // At most 64 cells per axis: a larger cloth gets larger cells.
    cell = std::max(cell, ext.maxCoeff() / 64.0);
    nx = clamped_cell(std::ceil(ext.x() / cell), 1, 64);
    ny = clamped_cell(std::ceil(ext.y() / cell), 1, 64);
    nz = clamped_cell(std::ceil(ext.z() / cell), 1, 64);
    const int cells = nx * ny * nz;
    std::vector<int> c(s.x.size());
    for (size_t i = 0; i < s.x.size(); ++i) c[i] = cell_of(s.x[i]);
    fill(c, cells, vert_start, verts);
    const auto& tri = mesh.triangles();
    c.resize(tri.size());
    tri_reach = 0.0;
    for (size_t t = 0; t < tri.size(); ++t) {
      const Vec3 m = (s.x[tri[t][0]] + s.x[tri[t][1]] + s.x[tri[t][2]]) / 3.0;
      for (int k = 0; k < 3; ++k) tri_reach = std::max(tri_reach, (s.x[tri[t][k]] - m).squaredNorm());
      c[t] = cell_of(m);
    }
    tri_reach = std::sqrt(tri_reach);
    fill(c, cells, tri_start, tris);
  }
  // Items of cells overlapping the box [qlo, qhi].
  template <class F>
  void query(const Vec3& qlo, const Vec3& qhi, const std::vector<int>& start, const std::vector<int>& items,
             F&& f) const {
    const Vec3 a = qlo - lo, b = qhi - lo;
    const int x0 = clamp_index(a.x(), nx), x1 = clamp_index(b.x(), nx);
    const int y0 = clamp_index(a.y(), ny), y1 = clamp_index(b.y(), ny);
    const int z0 = clamp_index(a.z(), nz), z1 = clamp_index(b.z(), nz);
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const int c = (z * ny + y) * nx + x;
          for (int k = start[c]; k < start[c + 1]; ++k) f(items[k]);
        }
  }
};

FeatureContactStage::FeatureContactStage(ColliderSetPtr colliders, FeatureContactSettings settings)
    : colliders_(std::move(colliders)), settings_(settings), grid_(std::make_unique<Grid>()) {
  if (!(settings_.face_slack >= 0.0 && settings_.face_slack < 1.0))
    throw Error("", "feature_contact.face_slack", "must be in [0, 1)");
}

FeatureContactStage::~FeatureContactStage() = default;

std::vector<std::pair<std::string, double>> FeatureContactStage::counters() const {
  return {{"vertex_contacts", static_cast<double>(vertex_contacts_)},
          {"face_contacts", static_cast<double>(face_contacts_)},
          {"swept_vertices", static_cast<double>(swept_vertices_)}};
}

void FeatureContactStage::run(cloth::StageContext& ctx) {
  last_penetration_ = 0.0;
  if (!colliders_ || colliders_->empty()) return;
  features_.resize(colliders_->size());
  for (size_t k = 0; k < colliders_->size(); ++k) {
    Collider& c = (*colliders_)[k];
    if ((c.shape.type == ShapeType::convex || c.shape.type == ShapeType::mesh) && !c.geometry)
      prepare_collider(c);
    features_[k] = settings_.faces ? collider_features(c) : ColliderFeatures{};
  }
  if (!settings_.vertices &&
      std::all_of(features_.begin(), features_.end(), [](const ColliderFeatures& f) { return f.a.empty(); }))
    return;  // face phase alone and no collider with features (planes, meshes)
  for (auto& cl : ctx.cloths) run_cloth(*cl, ctx.h);
}

namespace {

// Largest displacement of a triangle's vertex per unit of the depth it corrects (face phase): at most 3 for
// free vertices of equal mass, larger only when the point lies by held ones.
constexpr double kMaxLever = 4.0;

// Velocity response of a contact point with normal N (unit, from the body to the cloth): removes the
// approaching part of rel (the point's velocity relative to the body's) and applies Coulomb friction
// (Bridson et al. 2002, Sec. 7.2). Returns the wanted change of the point's velocity (zero if separating).
Vec3 contact_dv(const Vec3& rel, const Vec3& n, double mu_s, double mu_k) {
  const double vn = rel.dot(n);
  if (vn >= 0.0) return Vec3::Zero();
  const Vec3 vt = rel - vn * n;
  const double vt_norm = vt.norm();
  const double keep = vt_norm <= mu_s * (-vn) ? 0.0 : std::max(0.0, 1.0 - mu_k * (-vn) / vt_norm);
  return -vn * n + (keep - 1.0) * vt;
}

// Swept box of the collider (prev and curr), inflated by the thickness `thick` (m).
void swept_bounds(const Collider& col, const ColliderGeometry* geom, double thick, Vec3& blo, Vec3& bhi) {
  Vec3 llo, lhi;
  local_bounds(col.shape, geom, llo, lhi);
  blo = Vec3::Constant(HUGE_VAL), bhi = Vec3::Constant(-HUGE_VAL);
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 q((corner & 1) ? lhi.x() : llo.x(), (corner & 2) ? lhi.y() : llo.y(),
                 (corner & 4) ? lhi.z() : llo.z());
    for (const Transform* pose : {&col.prev, &col.curr}) {
      const Vec3 w = *pose * q;
      blo = blo.cwiseMin(w), bhi = bhi.cwiseMax(w);
    }
  }
  blo.array() -= thick;
  bhi.array() += thick;
}

}  // namespace

// Clips A + u (B - A), u in [u0, u1], to the prism over the triangle (a, b, c) with unit normal n.
// Returns false when nothing is left.
bool clip_to_prism(const Vec3& A, const Vec3& B, const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& n,
                   double& u0, double& u1) {
  // Clip A + u (B - A) to the prism over the triangle: (P - e0) . (n x (e1 - e0)) >= 0 per edge.
  bool empty = false;
  const Vec3* corners[3] = {&a, &b, &c};
  for (int j = 0; j < 3 && !empty; ++j) {
    const Vec3& e0 = *corners[j];
    const Vec3 m = n.cross(*corners[(j + 1) % 3] - e0);
    const double gA = (A - e0).dot(m), gB = (B - e0).dot(m);
    if (gA < 0.0 && gB < 0.0) {
      empty = true;
    } else if (gA < 0.0) {
      u0 = std::max(u0, gA / (gA - gB));
    } else if (gB < 0.0) {
      u1 = std::min(u1, gA / (gA - gB));
    }
    if (u0 > u1) empty = true;
  }
  return !empty;
}

// One collider's contact parameters for one cloth and step.
struct FeatureContactStage::ColliderPass {
  Collider& col;
  double thick;  // m, contact thickness
  double mu_k, mu_s;
  bool plane;
  const ColliderGeometry* geom;
  Transform inv_curr;
  Vec3 centre;    // m, the collider's origin at curr (reaction torques are about it)
  Vec3 blo, bhi;  // m, swept box of the collider, inflated by thick (unbounded for a plane)

  // Applies contact_dv at `point` for a point of inverse mass inv_w: `impulse` (N s) goes to the cloth, its
  // opposite (and torque) to the collider's reaction.
  void respond(const Vec3& rel, const Vec3& n, const Vec3& point, double inv_w, Vec3& impulse) const {
    const Vec3 dv = contact_dv(rel, n, mu_s, mu_k);
    impulse = dv / inv_w;  // N s given to the cloth at `point`
    col.reaction_impulse -= impulse;
    col.reaction_angular_impulse -= (point - centre).cross(impulse);
  }
};

void FeatureContactStage::run_cloth(cloth::Cloth& cloth, double h) {
  cloth::ClothState& s = cloth.state();
  const cloth::ClothMesh& mesh = cloth.mesh();
  const double thk = settings_.thickness > 0.0 ? settings_.thickness : cloth.material().thickness;
  Grid& grid = *grid_;
  grid.build(s, mesh);
  const bool have_prev = s.x_prev.size() == s.x.size();

  for (size_t k = 0; k < colliders_->size(); ++k) {
    Collider& col = (*colliders_)[k];
    const double thick = col.thickness > 0.0 ? col.thickness : thk;
    const double mu_k = settings_.friction.value_or(col.friction);
    const double mu_s = std::max(mu_k, settings_.static_friction.value_or(col.static_friction));
    const bool plane = col.shape.type == ShapeType::plane;
    ColliderPass pass{col,
                      thick,
                      mu_k,
                      mu_s,
                      plane,
                      col.geometry.get(),
                      col.curr.inverse(Eigen::Isometry),
                      col.curr.translation(),
                      Vec3::Constant(-HUGE_VAL),
                      Vec3::Constant(HUGE_VAL)};
    if (!plane) swept_bounds(col, pass.geom, thick, pass.blo, pass.bhi);

    gather_candidates(s, k, pass);
    if (cand_v_.empty() && cand_t_.empty()) continue;
    const ColliderFeatures& f = features_[k];
    const int nf = static_cast<int>(f.a.size());
    fa_.resize(nf), fb_.resize(nf), fa0_.resize(nf), fb0_.resize(nf);
    for (int e = 0; e < nf; ++e) {
      fa_[e] = col.curr * f.a[e], fb_[e] = col.curr * f.b[e];
      fa0_[e] = col.prev * f.a[e], fb0_[e] = col.prev * f.b[e];
    }

    for (int iter = 0; iter < std::max(1, settings_.iterations); ++iter) {
      // 1. Vertices.
      if (settings_.vertices) push_vertices(s, pass, h, iter == 0 && have_prev);
      // 2. Collider features against cloth triangles.
      push_triangles(s, mesh, pass, f, h, have_prev);
    }
  }
}

void FeatureContactStage::gather_candidates(const cloth::ClothState& s, size_t k, const ColliderPass& pass) {
  // Candidates once per collider and step.
  Grid& grid = *grid_;
  const Vec3 &blo = pass.blo, &bhi = pass.bhi;
  cand_v_.clear();
  cand_t_.clear();
  if (pass.plane) {
    if (settings_.vertices)
      for (int i = 0; i < s.size(); ++i) cand_v_.push_back(i);
  } else {
    if (settings_.vertices)
      grid.query(blo, bhi, grid.vert_start, grid.verts, [&](int i) {
        const Vec3& x = s.x[i];
        if ((x.array() >= blo.array()).all() && (x.array() <= bhi.array()).all()) cand_v_.push_back(i);
      });
    if (!features_[k].a.empty()) {
      const Vec3 r = Vec3::Constant(grid.tri_reach + features_[k].radius);
      grid.query(blo - r, bhi + r, grid.tri_start, grid.tris, [&](int t) { cand_t_.push_back(t); });
    }
  }
}

void FeatureContactStage::push_vertices(cloth::ClothState& s, const ColliderPass& pass, double h,
                                        bool swept) {
  const Collider& col = pass.col;
  const double thick = pass.thick;
  for (int i : cand_v_) {
    if (s.inv_mass[i] == 0.0) continue;
    Vec3& x = s.x[i];
    Vec3 nl;
    const double d = local_signed_distance(col.shape, pass.geom, pass.inv_curr * x, &nl);
    if (!(d < thick)) continue;
    last_penetration_ = std::max(last_penetration_, -d);
    Vec3 n = col.curr.linear() * nl;
    double push = thick - d;
    if (d < -thick && swept) {
      // Deeper than the thickness: the nearest face may not be the one it came through.
      const SweptHit hit = swept_point(col, s.x_prev[i], x, 0.5 * thick);
      if (hit.hit) {
        n = col.curr.linear() * hit.normal;
        push = thick - (pass.inv_curr * x - hit.local).dot(hit.normal);
        ++swept_vertices_;
      }
    }
    if (push <= 0.0) continue;
    ++vertex_contacts_;
    x += push * n;
    const Vec3 vb = surface_velocity(col.prev, col.curr, h, x);
    Vec3 impulse;
    pass.respond(s.v[i] - vb, n, x, s.inv_mass[i], impulse);
    s.v[i] += s.inv_mass[i] * impulse;
  }
}

void FeatureContactStage::push_triangles(cloth::ClothState& s, const cloth::ClothMesh& mesh,
                                         const ColliderPass& pass, const ColliderFeatures& f, double h,
                                         bool have_prev) {
  const Collider& col = pass.col;
  const double thick = pass.thick;
  const auto& tris = mesh.triangles();
  const int nf = static_cast<int>(f.a.size());
  for (int t : cand_t_) {
    const int ia = tris[t][0], ib = tris[t][1], ic = tris[t][2];
    const double wa = s.inv_mass[ia], wb = s.inv_mass[ib], wc = s.inv_mass[ic];
    if (wa == 0.0 && wb == 0.0 && wc == 0.0) continue;
    const Vec3 &a = s.x[ia], &b = s.x[ib], &c = s.x[ic];
    Vec3 n = (b - a).cross(c - a);
    const double n_len = n.norm();
    if (!(n_len > 1e-14)) continue;
    n /= n_len;
    const double reach = f.radius + thick;
    const double slack = settings_.face_slack * thick;  // m
    for (int e = 0; e < nf; ++e) {
      const Vec3 &A = fa_[e], &B = fb_[e];
      const double sA = (A - a).dot(n), sB = (B - a).dot(n);
      if ((sA > reach && sB > reach) || (sA < -reach && sB < -reach)) continue;
      double u0 = 0.0, u1 = 1.0;
      if (!clip_to_prism(A, B, a, b, c, n, u0, u1)) continue;
      // The side the feature was on at the step's start (its clipped middle against the old plane);
      // when it was closer than half the thickness to it, the side of the collider's centre.
      double side = 1.0;
      {
        const Vec3 &a0 = have_prev ? s.x_prev[ia] : a, &b0 = have_prev ? s.x_prev[ib] : b;
        const Vec3& c0 = have_prev ? s.x_prev[ic] : c;
        Vec3 n0 = (b0 - a0).cross(c0 - a0);
        n0 = n0.norm() > 1e-14 ? n0.normalized() : n;
        const double um = 0.5 * (u0 + u1);
        const double s0 = (fa0_[e] + um * (fb0_[e] - fa0_[e]) - a0).dot(n0);
        const double sc = (col.prev.translation() - a0).dot(n0);
        side = std::abs(s0) >= 0.5 * thick ? (s0 > 0.0 ? 1.0 : -1.0) : (sc >= 0.0 ? 1.0 : -1.0);
      }
      const double h0 = side * (sA + u0 * (sB - sA)), h1 = side * (sA + u1 * (sB - sA));
      const double u = h0 <= h1 ? u0 : u1;
      const double depth = reach - std::min(h0, h1);
      if (!(depth > slack)) continue;
      const Vec3 p = A + u * (B - A);
      // Barycentric weights of p's projection.
      const Vec3 q = p - (p - a).dot(n) * n;
      const double area = (b - a).cross(c - a).dot(n);
      if (!(area > 1e-14)) continue;
      double ba = (b - q).cross(c - q).dot(n) / area, bb = (c - q).cross(a - q).dot(n) / area;
      ba = std::clamp(ba, 0.0, 1.0), bb = std::clamp(bb, 0.0, 1.0 - ba);
      const double bc = 1.0 - ba - bb;
      const double inv_w = wa * ba * ba + wb * bb * bb + wc * bc * bc;
      if (!(inv_w > 0.0)) continue;
      // Vertex j moves by w_j b_j / inv_w times the depth. A point by held vertices (pins, attachments: a
      // cloth attached to this body) would fling its free vertices; there the held ones carry the contact.
      if (std::max({wa * ba, wb * bb, wc * bc}) > kMaxLever * inv_w) continue;
      // A held vertex of the triangle within the reach of this feature (a cloth attached to the body's
      // surface): the attachment holds the triangle there, a push would only stretch it.
      {
        bool held_here = false;
        const Vec3 ab = B - A;
        const double ab2 = ab.squaredNorm();
        for (int j : {ia, ib, ic}) {
          if (s.inv_mass[j] != 0.0) continue;
          const double tj = ab2 > 0.0 ? std::clamp((s.x[j] - A).dot(ab) / ab2, 0.0, 1.0) : 0.0;
          held_here |= (s.x[j] - (A + tj * ab)).norm() < reach;
        }
        if (held_here) continue;
      }
      ++face_contacts_;
      last_penetration_ = std::max(last_penetration_, depth - thick);
      const Vec3 N = -side * n;  // from the body to the cloth
      const Vec3 dx = (depth / inv_w) * N;
      s.x[ia] += wa * ba * dx, s.x[ib] += wb * bb * dx, s.x[ic] += wc * bc * dx;
      const Vec3 point = ba * s.x[ia] + bb * s.x[ib] + bc * s.x[ic];
      const Vec3 vb = surface_velocity(col.prev, col.curr, h, p);
      const Vec3 vp = ba * s.v[ia] + bb * s.v[ib] + bc * s.v[ic];
      Vec3 impulse;
      pass.respond(vp - vb, N, point, inv_w, impulse);
      s.v[ia] += wa * ba * impulse, s.v[ib] += wb * bb * impulse, s.v[ic] += wc * bc * impulse;
      // The triangle moved: refresh its plane for the next feature.
      n = (b - a).cross(c - a);
      const double len = n.norm();
      if (!(len > 1e-14)) break;
      n /= len;
    }
  }
}

}  // namespace loom::collision
