#include "BodyCoupling.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "loom/collision/ColliderDistance.h"
#include "loom/collision/ColliderGeometry.h"
#include "loom/collision/FeatureContact.h"

namespace loom::bullet {

using collision::Collider;
using collision::ShapeType;

namespace {

// A triangle corner whose barycentric weight at a feature contact is at least this counts as in contact.
constexpr double kCornerShare = 0.2;
// A vertex in contact moves its body only while it is within kTouch thicknesses of the contact point along
// the normal (1: at the contact offset).
constexpr double kTouch = 1.25;
// Vertices per block of the candidate search's culling boxes.
constexpr int kBlock = 16;

// Generalized inverse mass of body point r (m, from the centre of mass) along unit n (Müller et al. 2020,
// eq. 2): 1/M + (r x n)^T I^-1 (r x n).
double generalized_inv_mass(const CoupledBody& b, const Vec3& r, const Vec3& n) {
  if (!b.dynamic()) return 0.0;
  const Vec3 rn = r.cross(n);
  return b.inv_mass + rn.dot(b.inv_inertia * rn);
}

// Positional impulse P (kg m) at body point r (Müller et al. 2020, eqs. 6-8): x += P / M,
// q += 1/2 [I^-1 (r x P), 0] q.
void apply_positional_impulse(CoupledBody& b, const Vec3& P, const Vec3& r) {
  if (!b.dynamic()) return;
  b.pose.translation() += b.inv_mass * P;
  const Vec3 dtheta = b.inv_inertia * r.cross(P);
  Eigen::Quaterniond q(b.pose.linear());
  const Eigen::Quaterniond dq = Eigen::Quaterniond(0.0, dtheta.x(), dtheta.y(), dtheta.z()) * q;
  q.coeffs() += 0.5 * dq.coeffs();
  b.pose.linear() = q.normalized().toRotationMatrix();
  b.touched = true;
  ++b.version;
}

// Velocity u after a step that started with u_pred, cut so that the step's change du = u - u_pred, along
// d = du / |du|, stops the motion along d but does not reverse or raise it: u.d <= max(0, u_pred.d).
Vec3 no_rebound(const Vec3& u, const Vec3& u_pred, const std::vector<Vec3>& carried) {
  const Vec3 du = u - u_pred;
  const double len = du.norm();
  if (!(len > 0.0)) return u;
  const Vec3 d = du / len;
  double allowed = std::max(0.0, u_pred.dot(d));
  for (const Vec3& c : carried) allowed = std::max(allowed, c.dot(d));
  const double excess = u.dot(d) - allowed;
  return excess > 0.0 ? Vec3(u - excess * d) : u;
}

// Body velocities from the pose change over the step (Müller et al. 2020, Alg. 2).
void pose_velocities(const CoupledBody& b, double h, Vec3& v, Vec3& w) {
  v = (b.pose.translation() - b.pose0.translation()) / h;
  Eigen::Quaterniond dq =
      Eigen::Quaterniond(b.pose.linear()) * Eigen::Quaterniond(b.pose0.linear()).conjugate();
  if (dq.w() < 0.0) dq.coeffs() = -dq.coeffs();
  w = 2.0 * dq.vec() / h;
}

}  // namespace

// Collider k placed in the world now: its pose, the inverse, its features' end points, and their box grown
// by the features' radius, the thickness and the longest feature's length (m). Valid while `version` is its
// body's (0: no coupled body).
struct BodyCoupling::Placed {
  long version = -1, features_version = -1;  // of pose and inverse; of a, b, lo and hi
  Transform pose = Transform::Identity(), inverse = Transform::Identity();
  Transform prev = Transform::Identity();  // at the cloth step's start
  std::vector<Vec3> a, b;
  std::vector<double> length;  // m, per feature |b - a|
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();
  Vec3 centre = Vec3::Zero();  // m, the middle of the features' end points' box
  double extent = 0.0;         // m, the largest distance of an end point from `centre`
};

struct BodyCoupling::Work {
  struct Limit {
    int i = 0, j = 0;
    double length = 0.0;         // m, the largest allowed distance
    double length2_below = 0.0;  // m², a little below its square (1 - 1e-9 of it)
  };
  struct ClothData {
    bool built = false;
    std::vector<Limit> edges, tethers;  // tethers: i = free vertex, j = pinned anchor
    std::vector<std::vector<int>> vertex_tris;
    double max_edge = 0.0;  // m, longest allowed edge
  };
  std::vector<ClothData> cloths;
  // Per vertex, this cloth step: the collider of its contact with a coupled dynamic body (-1: none), the
  // contact normal (from the body to the vertex), the contact point in the collider's frame, and the summed
  // normal correction (m).
  std::vector<int> contact;
  std::vector<Vec3> normal, point_local;
  std::vector<double> depth;
  std::vector<std::pair<int, int>> vertex_pairs;  // (vertex, collider)
  std::vector<std::pair<int, int>> tri_pairs;     // (triangle, collider)
  std::vector<int> stamp;
  std::vector<collision::ColliderFeatures> features;
  std::vector<Placed> placed;            // per collider
  std::vector<Vec3> block_lo, block_hi;  // m, per block of kBlock vertices: the box of their positions
  std::vector<Vec3> anchor_v;  // m/s, this cloth step's velocities of the pinned vertices, all cloths
};

class BodyCoupling::Predict final : public cloth::Stage {
 public:
  explicit Predict(BodyCoupling& o) : o_(o) {}
  const char* name() const override { return "body_coupling_predict"; }
  void run(cloth::StageContext& ctx) override { o_.predict(ctx.h); }

 private:
  BodyCoupling& o_;
};

class BodyCoupling::Solve final : public cloth::Stage {
 public:
  explicit Solve(BodyCoupling& o) : o_(o) {}
  const char* name() const override { return "body_coupling"; }
  void run(cloth::StageContext& ctx) override {
    o_.last_penetration_ = 0.0;
    o_.work_->anchor_v.clear();
    for (size_t c = 0; c < ctx.cloths.size(); ++c) o_.solve(*ctx.cloths[c], c, ctx.h);
    o_.update_body_velocities(ctx.h);
    collision::ColliderSet& cs = *o_.colliders_;
    for (size_t k = 0; k < cs.size(); ++k)
      if (o_.collider_body[k] >= 0) cs[k].curr = o_.bodies[o_.collider_body[k]].pose * o_.collider_local[k];
  }
  std::vector<std::pair<std::string, double>> counters() const override {
    return {{"vertex_contacts", static_cast<double>(o_.vertex_contacts_)},
            {"face_contacts", static_cast<double>(o_.face_contacts_)}};
  }

 private:
  BodyCoupling& o_;
};

BodyCoupling::BodyCoupling(collision::ColliderSetPtr colliders, BodyCouplingSettings settings)
    : colliders_(std::move(colliders)), settings_(settings), work_(std::make_unique<Work>()) {}

BodyCoupling::~BodyCoupling() = default;

std::unique_ptr<cloth::Stage> BodyCoupling::make_predict_stage() { return std::make_unique<Predict>(*this); }
std::unique_ptr<cloth::Stage> BodyCoupling::make_solve_stage() { return std::make_unique<Solve>(*this); }

void BodyCoupling::predict(double h) {
  for (CoupledBody& b : bodies) {
    b.pose0 = b.pose;
    b.v_pred = b.v;
    b.w_pred = b.w;
    if (!b.dynamic()) continue;
    b.pose.translation() += h * b.v;
    Eigen::Quaterniond q(b.pose.linear());
    const Eigen::Quaterniond dq = Eigen::Quaterniond(0.0, b.w.x(), b.w.y(), b.w.z()) * q;
    q.coeffs() += 0.5 * h * dq.coeffs();
    const Mat3 R = q.normalized().toRotationMatrix();
    b.pose.linear() = R;
    ++b.version;
    b.inv_inertia = R * b.inv_inertia_local.asDiagonal() * R.transpose();
  }
  collision::ColliderSet& cs = *colliders_;
  for (size_t k = 0; k < cs.size() && k < collider_body.size(); ++k) {
    if (collider_body[k] < 0) continue;
    const CoupledBody& b = bodies[collider_body[k]];
    cs[k].prev = b.pose0 * collider_local[k];
    cs[k].curr = b.pose * collider_local[k];
  }
}

CoupledBody* BodyCoupling::body_of(int k) {
  return k < static_cast<int>(collider_body.size()) && collider_body[k] >= 0 ? &bodies[collider_body[k]]
                                                                             : nullptr;
}

const BodyCoupling::Placed& BodyCoupling::placed(int k) {
  Placed& pl = work_->placed[k];
  const CoupledBody* b = body_of(k);
  const long version = b ? b->version : 0;
  if (pl.version != version) {
    pl.version = version;
    pl.pose = b ? b->pose * collider_local[k] : (*colliders_)[k].curr;
    pl.inverse = pl.pose.inverse(Eigen::Isometry);
  }
  return pl;
}

const BodyCoupling::Placed& BodyCoupling::placed_features(int k) {
  Placed& pl = work_->placed[k];
  placed(k);
  if (pl.features_version == pl.version) return pl;
  pl.features_version = pl.version;
  const collision::ColliderFeatures& f = work_->features[k];
  pl.a.resize(f.a.size());
  pl.b.resize(f.b.size());
  pl.lo = Vec3::Constant(HUGE_VAL);
  pl.hi = Vec3::Constant(-HUGE_VAL);
  for (size_t e = 0; e < f.a.size(); ++e) {
    pl.a[e] = pl.pose * f.a[e];
    pl.b[e] = pl.pose * f.b[e];
    pl.lo = pl.lo.cwiseMin(pl.a[e]).cwiseMin(pl.b[e]);
    pl.hi = pl.hi.cwiseMax(pl.a[e]).cwiseMax(pl.b[e]);
  }
  // A contact needs a feature's part over the triangle within its reach of the plane at one end: that part
  // is within the reach plus the feature's length of the triangle.
  pl.length.resize(f.a.size());
  double length = 0.0;
  for (size_t e = 0; e < f.a.size(); ++e) {
    pl.length[e] = (f.b[e] - f.a[e]).norm();
    length = std::max(length, pl.length[e]);
  }
  pl.centre = 0.5 * (pl.lo + pl.hi);
  pl.extent = 0.0;
  for (size_t e = 0; e < f.a.size(); ++e)
    pl.extent = std::max({pl.extent, (pl.a[e] - pl.centre).norm(), (pl.b[e] - pl.centre).norm()});
  const double grow = f.radius + settings_.thickness + length;
  pl.lo.array() -= grow;
  pl.hi.array() += grow;
  return pl;
}

// A vertex moving along unit m with multiplier lam (displacement lam W m): contact-aware (see header).
double BodyCoupling::effective_inv_mass(const cloth::ClothState& s, int i, const Vec3& m) {
  const Work& w = *work_;
  const double thick = settings_.thickness;
  const double wv = s.inv_mass[i];
  const int k = w.contact[i];
  if (k < 0 || wv == 0.0 || !body_of(k) || !body_of(k)->dynamic()) return wv;
  const double mn = m.dot(w.normal[i]);
  if (mn >= 0.0) return wv;
  const CoupledBody& b = *body_of(k);
  const Vec3 p = placed(k).pose * w.point_local[i];
  if ((s.x[i] - p).dot(w.normal[i]) > kTouch * thick) return wv;  // no longer touching
  const double wb = generalized_inv_mass(b, p - b.pose.translation(), w.normal[i]);
  const double wc = wv * wb / (wv + wb);
  return wv * (1.0 - mn * mn) + wc * mn * mn;
}

// Moves vertex i by lam W m, W as in effective_inv_mass; the normal share of a coupled contact moves its
// body back (positional impulse).
void BodyCoupling::move_vertex(cloth::ClothState& s, int i, double lam, const Vec3& m) {
  const Work& w = *work_;
  const double thick = settings_.thickness;
  const double wv = s.inv_mass[i];
  if (wv == 0.0) return;
  const int k = w.contact[i];
  const bool coupled = k >= 0 && body_of(k) && body_of(k)->dynamic();
  const double mn = coupled ? m.dot(w.normal[i]) : 0.0;
  if (!coupled || mn >= 0.0) {
    s.x[i] += (lam * wv) * m;
    return;
  }
  const Vec3 p = placed(k).pose * w.point_local[i];
  if ((s.x[i] - p).dot(w.normal[i]) > kTouch * thick) {
    s.x[i] += (lam * wv) * m;
    return;
  }
  CoupledBody& b = *body_of(k);
  const Vec3& nrm = w.normal[i];
  const Vec3 r = p - b.pose.translation();
  const double wb = generalized_inv_mass(b, r, nrm);
  const double wc = wv * wb / (wv + wb);
  s.x[i] += lam * (wv * (m - mn * nrm) + wc * mn * nrm);
  apply_positional_impulse(b, (lam * mn * wv / (wv + wb)) * nrm, r);
}

// Inelastic contacts (Müller et al. 2020, Sec. 3.6, eq. 34 with restitution 0): each vertex still within
// kTouch thicknesses of its contact point ends the step with the body point's normal velocity,
// v_n = (v_vertex - v_point).n -> 0, by an equal and opposite impulse -v_n / (w_v + w_b) on vertex and body
// at the vertex's position (the body's share is added to its velocity from the pose change).
void BodyCoupling::contact_velocities(cloth::ClothState& s, double h) {
  const Work& w = *work_;
  const double thick = settings_.thickness;
  const int n = s.size();
  for (int i = 0; i < n; ++i) {
    const int k = w.contact[i];
    const double wv = s.inv_mass[i];
    if (k < 0 || wv == 0.0) continue;
    const Vec3& nrm = w.normal[i];
    const Vec3 p = placed(k).pose * w.point_local[i];
    if ((s.x[i] - p).dot(nrm) > kTouch * thick) continue;  // no longer touching
    CoupledBody* b = body_of(k);
    Vec3 vp = Vec3::Zero(), r = Vec3::Zero();
    double wb = 0.0;
    if (b && b->dynamic()) {
      Vec3 bv, bw;
      pose_velocities(*b, h, bv, bw);
      r = s.x[i] - b->pose.translation();  // at the vertex: the pair's angular momentum is kept exactly
      vp = bv + b->dv + (bw + b->dw).cross(r);
      wb = generalized_inv_mass(*b, r, nrm);
    } else {
      const Placed& pl = placed(k);
      vp = (p - pl.prev * w.point_local[i]) / h;
    }
    const double vn = (s.v[i] - vp).dot(nrm);
    if (vn == 0.0) continue;
    const double P = -vn / (wv + wb);  // normal impulse (kg m/s) on the vertex
    s.v[i] += (wv * P) * nrm;
    if (wb > 0.0) {
      b->dv -= (b->inv_mass * P) * nrm;
      b->dw -= b->inv_inertia * r.cross(P * nrm);
    }
  }
}

void BodyCoupling::update_body_velocities(double h) {
  for (CoupledBody& b : bodies) {
    if (!b.dynamic()) continue;
    pose_velocities(b, h, b.v, b.w);
    b.v += b.dv, b.w += b.dw;
    b.dv.setZero(), b.dw.setZero();
    // No rebound: v.d <= max(0, v_pred.d) along the direction d of the step's velocity change, and likewise
    // for w; only against a cloth with pinned vertices (a free cloth keeps the pair's momentum exactly).
    if (!anchored_) continue;
    b.v = no_rebound(b.v, b.v_pred, work_->anchor_v);
    b.w = no_rebound(b.w, b.w_pred, {});
  }
}

void BodyCoupling::build_limits(const cloth::Cloth& cloth, size_t index) {
  const cloth::ClothState& s = cloth.state();
  const cloth::ClothMesh& mesh = cloth.mesh();
  const int n = s.size();
  const double tau = settings_.max_stretch;
  Work::ClothData& cd = work_->cloths[index];
  // Limited edges: structural, shear and mesh edges (as StrainLimitStage).
  for (const cloth::SpringDef& sp : mesh.springs()) {
    if (sp.kind != cloth::SpringKind::kStructural && sp.kind != cloth::SpringKind::kShear &&
        sp.kind != cloth::SpringKind::kEdge)
      continue;
    const double L = (mesh.rest_positions()[sp.j] - mesh.rest_positions()[sp.i]).norm();
    const double length = (1.0 + tau) * L;
    cd.edges.push_back({sp.i, sp.j, length, (1.0 - 1e-9) * length * length});
    cd.max_edge = std::max(cd.max_edge, (1.0 + tau) * L);
  }
  // Tethers to the nearest pinned vertices at rest (straight rest distance).
  std::vector<int> pinned;
  for (int i = 0; i < n; ++i)
    if (s.inv_mass[i] == 0.0) pinned.push_back(i);
  anchored_ = anchored_ || !pinned.empty();
  const int per = std::min<int>(settings_.tether_anchors, static_cast<int>(pinned.size()));
  std::vector<std::pair<double, int>> near;
  for (int i = 0; i < n && per > 0; ++i) {
    if (s.inv_mass[i] == 0.0) continue;
    near.clear();
    for (int a : pinned) near.emplace_back((mesh.rest_positions()[a] - mesh.rest_positions()[i]).norm(), a);
    std::partial_sort(near.begin(), near.begin() + per, near.end());
    for (int k = 0; k < per; ++k) {
      const double length = (1.0 + settings_.tether_stretch) * near[k].first;
      cd.tethers.push_back({i, near[k].second, length, (1.0 - 1e-9) * length * length});
    }
  }
  cd.vertex_tris.assign(n, {});
  for (int t = 0; t < static_cast<int>(mesh.triangles().size()); ++t)
    for (int k = 0; k < 3; ++k) cd.vertex_tris[mesh.triangles()[t][k]].push_back(t);
}

void BodyCoupling::find_candidates(const cloth::Cloth& cloth, size_t index) {
  Work& w = *work_;
  const cloth::ClothState& s = cloth.state();
  const int n = s.size();
  const Work::ClothData& cd = w.cloths[index];
  collision::ColliderSet& cs = *colliders_;
  const int nc = static_cast<int>(cs.size());
  const double thick = settings_.thickness;
  // Boxes of blocks of kBlock consecutive vertices (neighbours in a grid's row, mostly), so a collider
  // skips the blocks out of its reach.
  const int blocks = (n + kBlock - 1) / kBlock;
  w.block_lo.assign(blocks, Vec3::Constant(HUGE_VAL));
  w.block_hi.assign(blocks, Vec3::Constant(-HUGE_VAL));
  for (int i = 0; i < n; ++i) {
    w.block_lo[i / kBlock] = w.block_lo[i / kBlock].cwiseMin(s.x[i]);
    w.block_hi[i / kBlock] = w.block_hi[i / kBlock].cwiseMax(s.x[i]);
  }
  // Candidates: vertices in the collider's box grown by the thickness (contacts), triangles touching a
  // vertex in the box grown by the longest edge (features).
  for (int k = 0; k < nc; ++k) {
    Collider& col = cs[k];
    if ((col.shape.type == ShapeType::convex || col.shape.type == ShapeType::mesh) && !col.geometry)
      collision::prepare_collider(col);
    const CoupledBody* b = body_of(k);
    if (!features_current_)
      w.features[k] = settings_.features && b && b->dynamic() ? collision::collider_features(col)
                                                              : collision::ColliderFeatures{};
    w.placed[k].version = w.placed[k].features_version = -1;
    w.placed[k].prev = b ? b->pose0 * collider_local[k] : col.prev;
    if (col.shape.type == ShapeType::plane) {
      for (int i = 0; i < n; ++i) w.vertex_pairs.emplace_back(i, k);
      continue;
    }
    Vec3 llo, lhi;
    collision::local_bounds(col.shape, col.geometry.get(), llo, lhi);
    Vec3 blo = Vec3::Constant(HUGE_VAL), bhi = Vec3::Constant(-HUGE_VAL);
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 q((corner & 1) ? lhi.x() : llo.x(), (corner & 2) ? lhi.y() : llo.y(),
                   (corner & 4) ? lhi.z() : llo.z());
      for (const Transform* pose : {&col.prev, &col.curr}) {
        const Vec3 p = *pose * q;
        blo = blo.cwiseMin(p), bhi = bhi.cwiseMax(p);
      }
    }
    const double near = 2.0 * thick;
    const double far = w.features[k].a.empty() ? near : near + cd.max_edge;
    const Vec3 flo = blo.array() - far, fhi = bhi.array() + far;
    const Vec3 nlo = blo.array() - near, nhi = bhi.array() + near;
    for (int i = 0; i < n; ++i) {
      if (i % kBlock == 0 && ((w.block_hi[i / kBlock].array() < flo.array()).any() ||
                              (w.block_lo[i / kBlock].array() > fhi.array()).any())) {
        i += kBlock - 1;
        continue;
      }
      const Vec3& x = s.x[i];
      if ((x.array() < flo.array()).any() || (x.array() > fhi.array()).any()) continue;
      if ((x.array() >= nlo.array()).all() && (x.array() <= nhi.array()).all())
        w.vertex_pairs.emplace_back(i, k);
      if (w.features[k].a.empty()) continue;
      for (int t : cd.vertex_tris[i])
        if (w.stamp[t] != k) w.stamp[t] = k, w.tri_pairs.emplace_back(t, k);
    }
  }
}

void BodyCoupling::colliders_changed() { features_current_ = false; }

// Contacts: vertices against bodies.
void BodyCoupling::solve_vertex_contacts(cloth::ClothState& s, int it) {
  Work& w = *work_;
  const collision::ColliderSet& cs = *colliders_;
  const double thick = settings_.thickness;
  for (const auto& [i, k] : w.vertex_pairs) {
    const double wv = s.inv_mass[i];
    if (wv == 0.0) continue;
    const Collider& col = cs[k];
    const Placed& pl = placed(k);
    Vec3 nl;
    const double d =
        collision::local_signed_distance(col.shape, col.geometry.get(), pl.inverse * s.x[i], &nl);
    if (!(d < thick)) continue;
    if (it == 0) last_penetration_ = std::max(last_penetration_, -d);
    ++vertex_contacts_;
    const Vec3 nrm = pl.pose.linear() * nl;
    const Vec3 p = s.x[i] - d * nrm;  // on the surface
    w.point_local[i] = pl.inverse * p;
    CoupledBody* b = body_of(k);
    const Vec3 r = b ? Vec3(p - b->pose.translation()) : Vec3::Zero();
    const double wb = b ? generalized_inv_mass(*b, r, nrm) : 0.0;
    const double dl = (thick - d) / (wv + wb);
    s.x[i] += (wv * dl) * nrm;
    if (b) apply_positional_impulse(*b, -dl * nrm, r);
    w.depth[i] += thick - d;
    w.contact[i] = k;
    w.normal[i] = nrm;
  }
}

// Contacts: body features against cloth triangles (FeatureContact.h, phase 2, mass-aware).
void BodyCoupling::solve_feature_contacts(cloth::Cloth& cloth, int it) {
  Work& w = *work_;
  cloth::ClothState& s = cloth.state();
  const auto& tris = cloth.mesh().triangles();
  const bool have_prev = s.x_prev.size() == s.x.size();
  const double thick = settings_.thickness;
  for (const auto& [t, k] : w.tri_pairs) {
    const collision::ColliderFeatures& f = w.features[k];
    CoupledBody& b = *body_of(k);
    const int ia = tris[t][0], ib = tris[t][1], ic = tris[t][2];
    const double wa = s.inv_mass[ia], wb_ = s.inv_mass[ib], wc_ = s.inv_mass[ic];
    if (wa == 0.0 && wb_ == 0.0 && wc_ == 0.0) continue;
    // The collider where it is at this pair's start (its features' positions are not updated for the body's
    // motion by this triangle's own contacts). Culling: the triangle's box against the features' box.
    const Placed& pl = placed_features(k);
    {
      const Vec3 tlo = s.x[ia].cwiseMin(s.x[ib]).cwiseMin(s.x[ic]);
      const Vec3 thi = s.x[ia].cwiseMax(s.x[ib]).cwiseMax(s.x[ic]);
      if ((tlo.array() > pl.hi.array()).any() || (thi.array() < pl.lo.array()).any()) continue;
    }
    const Transform& inverse = pl.inverse;
    const std::vector<Vec3>&fa = pl.a, &fb = pl.b;
    const double reach = f.radius + thick;
    // The triangle's unit normal, recomputed only after a contact moved its vertices.
    Vec3 nrm;
    double area = 0.0;
    bool moved = true;
    for (size_t e = 0; e < f.a.size(); ++e) {
      const Vec3 &a = s.x[ia], &bb = s.x[ib], &c = s.x[ic];
      const Vec3 &A = fa[e], &B = fb[e];
      // The segment's box grown by the reach and its length against the triangle's box (as in
      // placed_features).
      const double grow = reach + pl.length[e];
      const Vec3 slo = A.cwiseMin(B).array() - grow, shi = A.cwiseMax(B).array() + grow;
      if ((a.array() < slo.array() && bb.array() < slo.array() && c.array() < slo.array()).any() ||
          (a.array() > shi.array() && bb.array() > shi.array() && c.array() > shi.array()).any())
        continue;
      if (moved) {
        nrm = (bb - a).cross(c - a);
        area = nrm.norm();
        if (!(area > 1e-14)) break;
        nrm /= area;
        moved = false;
        // Every feature point farther than the reach on one side of the plane: no contact.
        const double sc = (pl.centre - a).dot(nrm);
        if (std::abs(sc) > pl.extent + reach + 1e-9) break;
      }
      const double sA = (A - a).dot(nrm), sB = (B - a).dot(nrm);
      if ((sA > reach && sB > reach) || (sA < -reach && sB < -reach)) continue;
      double u0 = 0.0, u1 = 1.0;
      if (!collision::clip_to_prism(A, B, a, bb, c, nrm, u0, u1)) continue;
      // The side the feature was on at the step's start (its clipped middle against the old plane); the
      // side of the body's centre when it was closer than half the thickness.
      double side = 1.0;
      {
        const Vec3 &a0 = have_prev ? s.x_prev[ia] : a, &b0 = have_prev ? s.x_prev[ib] : bb;
        const Vec3& c0 = have_prev ? s.x_prev[ic] : c;
        Vec3 n0 = (b0 - a0).cross(c0 - a0);
        n0 = n0.norm() > 1e-14 ? n0.normalized() : nrm;
        const double um = 0.5 * (u0 + u1);
        const Vec3 A0 = pl.prev * f.a[e], B0 = pl.prev * f.b[e];
        const double s0 = (A0 + um * (B0 - A0) - a0).dot(n0);
        const double sc = (pl.prev.translation() - a0).dot(n0);
        side = std::abs(s0) >= 0.5 * thick ? (s0 > 0.0 ? 1.0 : -1.0) : (sc >= 0.0 ? 1.0 : -1.0);
      }
      const double h0 = side * (sA + u0 * (sB - sA)), h1 = side * (sA + u1 * (sB - sA));
      const double u = h0 <= h1 ? u0 : u1;
      const double depth = reach - std::min(h0, h1);
      if (!(depth > 0.0)) continue;
      const Vec3 p = A + u * (B - A);
      const Vec3 q = p - (p - a).dot(nrm) * nrm;
      double ba = (bb - q).cross(c - q).dot(nrm) / area, bbw = (c - q).cross(a - q).dot(nrm) / area;
      ba = std::clamp(ba, 0.0, 1.0), bbw = std::clamp(bbw, 0.0, 1.0 - ba);
      const double bc = 1.0 - ba - bbw;
      const double w_tri = wa * ba * ba + wb_ * bbw * bbw + wc_ * bc * bc;
      if (!(w_tri > 0.0)) continue;
      ++face_contacts_;
      if (it == 0) last_penetration_ = std::max(last_penetration_, depth - thick);
      const Vec3 N = -side * nrm;  // from the body to the cloth
      const Vec3 r = q - side * f.radius * nrm - b.pose.translation();
      const double wbody = generalized_inv_mass(b, r, N);
      const double dl = depth / (w_tri + wbody);
      s.x[ia] += (wa * ba * dl) * N, s.x[ib] += (wb_ * bbw * dl) * N, s.x[ic] += (wc_ * bc * dl) * N;
      moved = true;
      // The triangle's vertices are in contact with the body at the feature's surface point: tethers and
      // edges pulling them into it move the body too.
      const Vec3 surface = inverse * (p + f.radius * N);
      const int corner_ids[3] = {ia, ib, ic};
      const double weights[3] = {ba, bbw, bc};
      for (int j = 0; j < 3; ++j) {
        if (weights[j] < kCornerShare) continue;
        const int v = corner_ids[j];
        w.contact[v] = k;
        w.normal[v] = N;
        w.point_local[v] = surface;
        w.depth[v] += weights[j] * depth;
      }
      apply_positional_impulse(b, -dl * N, r);
    }
  }
}

void BodyCoupling::solve_limits(cloth::ClothState& s, size_t index, int it) {
  const Work& w = *work_;
  const Work::ClothData& cd = w.cloths[index];
  // Tethers.
  for (const Work::Limit& l : cd.tethers) {
    const Vec3 d = s.x[l.i] - s.x[l.j];
    const double len2 = d.squaredNorm();
    if (len2 < l.length2_below) continue;  // clearly within (no square root)
    const double len = std::sqrt(len2);
    if (!(len > l.length)) continue;
    const Vec3 m = -d / len;
    if (w.contact[l.i] < 0) {  // not touching a body: the vertex alone (move_vertex's lam = C / w, times w)
      const double wi = s.inv_mass[l.i];
      if (!(wi > 0.0)) continue;
      s.x[l.i] += ((len - l.length) / wi * wi) * m;
      continue;
    }
    const double wi = effective_inv_mass(s, l.i, m);
    if (!(wi > 0.0)) continue;
    move_vertex(s, l.i, (len - l.length) / wi, m);
  }
  // Edges, alternating sweep order.
  const int ne = static_cast<int>(cd.edges.size());
  for (int q = 0; q < ne; ++q) {
    const Work::Limit& l = cd.edges[it % 2 == 0 ? q : ne - 1 - q];
    const Vec3 d = s.x[l.j] - s.x[l.i];
    const double len2 = d.squaredNorm();
    if (len2 < l.length2_below) continue;  // clearly within (no square root)
    const double len = std::sqrt(len2);
    if (!(len > l.length)) continue;
    const Vec3 u = d / len;
    if (w.contact[l.i] < 0 && w.contact[l.j] < 0) {  // neither touches a body
      const double wi = s.inv_mass[l.i], wj = s.inv_mass[l.j];
      if (!(wi + wj > 0.0)) continue;
      const double lam = (len - l.length) / (wi + wj);
      s.x[l.i] += (lam * wi) * u;
      s.x[l.j] -= (lam * wj) * u;
      continue;
    }
    const double wi = effective_inv_mass(s, l.i, u), wj = effective_inv_mass(s, l.j, -u);
    if (!(wi + wj > 0.0)) continue;
    const double lam = (len - l.length) / (wi + wj);
    move_vertex(s, l.i, lam, u);
    move_vertex(s, l.j, lam, -u);
  }
}

// Friction (Macklin et al. 2014, Sec. 6.1) on the vertex contacts; needs the step-start positions.
void BodyCoupling::apply_friction(cloth::ClothState& s) {
  const Work& w = *work_;
  const int n = s.size();
  const double mu_k = settings_.friction, mu_s = std::max(settings_.friction, settings_.static_friction);
  for (int i = 0; i < n; ++i) {
    const int k = w.contact[i];
    if (k < 0 || s.inv_mass[i] == 0.0) continue;
    const Vec3& nrm = w.normal[i];
    const Placed& pl = placed(k);
    const Vec3 p = pl.pose * w.point_local[i], p0 = pl.prev * w.point_local[i];
    const Vec3 dp = (s.x[i] - s.x_prev[i]) - (p - p0);
    const Vec3 dt = dp - dp.dot(nrm) * nrm;
    const double len = dt.norm();
    if (!(len > 1e-12)) continue;
    const double depth = w.depth[i];
    const double corr = len < mu_s * depth ? len : std::min(len, mu_k * depth);
    const Vec3 t = dt / len;
    CoupledBody* b = body_of(k);
    const Vec3 r = b ? Vec3(p - b->pose.translation()) : Vec3::Zero();
    const double wv = s.inv_mass[i], wb = b ? generalized_inv_mass(*b, r, t) : 0.0;
    const double lam = corr / (wv + wb);
    s.x[i] -= (wv * lam) * t;
    if (b) apply_positional_impulse(*b, lam * t, r);
  }
}

void BodyCoupling::solve(cloth::Cloth& cloth, size_t index, double h) {
  Work& w = *work_;
  cloth::ClothState& s = cloth.state();
  const cloth::ClothMesh& mesh = cloth.mesh();
  const int n = s.size();
  if (w.cloths.size() <= index) w.cloths.resize(index + 1);
  if (!w.cloths[index].built) {
    build_limits(cloth, index);
    w.cloths[index].built = true;
  }

  const int nc = static_cast<int>(colliders_->size());
  w.contact.assign(n, -1);
  w.normal.resize(n);
  w.point_local.resize(n);
  w.depth.assign(n, 0.0);
  w.vertex_pairs.clear();
  w.tri_pairs.clear();
  w.stamp.assign(mesh.triangles().size(), -1);
  w.placed.resize(nc);
  if (w.features.size() != static_cast<size_t>(nc)) features_current_ = false;
  w.features.resize(nc);
  find_candidates(cloth, index);
  if (index + 1 == w.cloths.size()) features_current_ = true;

  const bool have_prev = s.x_prev.size() == s.x.size();
  const int iterations = std::max(1, settings_.iterations);
  for (int it = 0; it < iterations; ++it) {
    solve_vertex_contacts(s, it);
    solve_feature_contacts(cloth, it);
    solve_limits(s, index, it);
  }

  if (have_prev) apply_friction(s);

  // Velocities from the corrected positions.
  if (have_prev)
    for (int i = 0; i < n; ++i) {
      const Vec3 v = (s.x[i] - s.x_prev[i]) / h;
      if (s.inv_mass[i] > 0.0) {
        s.v[i] = v;
      } else if (v.squaredNorm() > 0.0) {
        w.anchor_v.push_back(v);
      }
    }
  if (have_prev) contact_velocities(s, h);
}

}  // namespace loom::bullet
