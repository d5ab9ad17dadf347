// Self-collision proximity phase (SelfCollisionStage.h, step 1): repulsion and friction impulses for
// features closer than the thickness at the step start (Bridson, Fedkiw & Anderson 2002, Sec. 7.2-7.3).
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "SelfCollisionInternal.h"
#include "loom/collision/BodyCollisionStage.h"
#include "loom/collision/Ccd.h"
#include "loom/collision/Distance.h"
#include "loom/collision/SelfCollisionStage.h"

namespace loom::collision {

using loom::cloth::Mat3;
using loom::cloth::Tri;
using loom::cloth::Vec3s;
using namespace self_collision_detail;

// Shares beta_k of a contact's velocity change dv per vertex (vertex k changes by beta_k dv), with
// sum_k w_k beta_k = 1 so the contact's relative velocity changes by dv. Bridson et al. 2002, Sec. 7.1 take
// the least mass-weighted change, beta_k = lambda w_k m_k^-1 with lambda = 1 / sum_j w_j^2 m_j^-1 (m^-1 = the
// stage's inverse masses `im`). The same least change under the bound |beta_k| <= cap: beta_k =
// sign(w_k) min(cap, lambda |w_k| m_k^-1), with lambda raised until the constraint holds again (the vertices
// over the bound are capped one round at a time; once capped, a vertex stays capped as lambda only grows).
// Without the bound, a contact point next to a vertex the body stage left near a collider (1000 times heavier
// here) is moved by flicking the feature's far vertex at 1/w_k times the contact's change. Where only
// vertices that cannot move (m^-1 = 0) could take the rest, every vertex that can move takes the bound and
// the rest of the change is left to the next pass and the impact zones (Bridson's unbounded shares would
// flick a free vertex at many times the contact's change there).
bool capped_shares(const double w[4], const double im[4], int first, double cap, double beta[4]) {
  double denom = 0.0;
  for (int k = 0; k < 4; ++k) denom += w[k] * w[k] * im[k];
  if (!(denom > 0.0)) return false;
  for (int k = 0; k < 4; ++k) beta[k] = w[k] * im[k] / denom;
  if (!(cap > 0.0)) return true;
  bool capped[4] = {false, false, false, false};
  for (;;) {  // each further round caps at least one more movable vertex: at most 5 rounds
    double rest = 1.0, free_denom = 0.0;
    for (int k = 0; k < 4; ++k) {
      if (capped[k])
        rest -= cap * std::abs(w[k]);
      else
        free_denom += w[k] * w[k] * im[k];
    }
    // Infeasible: every movable vertex of the contact is at the bound (or, by rounding, the capped ones
    // already give the whole change). Every movable vertex of both features takes the bound on its feature's
    // side, those with w_k = 0 too (a contact on a triangle's edge): each feature moves as a block and keeps
    // its shape. Moving only the w_k != 0 vertices would shear the features into new intersections
    // (tests/stability, crushed_in_shrinking_box_to_30_cm_pbd).
    if (!(free_denom > 0.0) || !(rest > 0.0)) {
      for (int k = 0; k < 4; ++k) beta[k] = im[k] > 0.0 ? (k < first ? cap : -cap) : 0.0;
      return true;
    }
    const double lambda = rest / free_denom;
    bool more = false;
    for (int k = 0; k < 4; ++k)
      if (!capped[k] && lambda * std::abs(w[k]) * im[k] > cap * (1.0 + 1e-9))
        capped[k] = more = true;  // rounding
    if (more) continue;
    for (int k = 0; k < 4; ++k) beta[k] = capped[k] ? std::copysign(cap, w[k]) : lambda * w[k] * im[k];
    return true;
  }
}

namespace self_collision_detail {

void apply_impulses(const std::vector<Impulse>& imp, double h, Vec3s& x1, std::vector<char>* moved) {
  std::vector<int> touched;
  static thread_local std::vector<Vec3> sum;
  static thread_local std::vector<int> count;
  if (sum.size() < x1.size()) sum.assign(x1.size(), Vec3::Zero()), count.assign(x1.size(), 0);
  for (const Impulse& im : imp) {
    if (!im.active) continue;
    for (int k = 0; k < 4; ++k) {
      const int v = im.v[k];
      if (im.dv[k].isZero(0.0)) continue;
      if (count[v] == 0) touched.push_back(v);
      sum[v] += im.dv[k];
      ++count[v];
    }
  }
  for (int v : touched) {
    x1[v] += h * (sum[v] / count[v]);
    if (moved) (*moved)[v] = 1;
    sum[v].setZero();
    count[v] = 0;
  }
}

}  // namespace self_collision_detail

// Bridson et al. 2002, Sec. 7.2: pairs closer than the thickness at the step's start get an impulse that
// removes `repulsion` of the overlap per step along the normal; Sec. 7.3: Coulomb friction clamps the
// tangential relative velocity by mu * (normal velocity change) (static: stop it entirely).
void SelfCollisionStage::proximity(std::vector<Feature>& fs, int threads, std::vector<char>& moved) {
  PhaseTimer timer(proximity_ms_);
  const long n = static_cast<long>(fs.size());
  const std::vector<Impulse> imp = collect_impulses(n, threads, [&](long i, std::vector<Impulse>& out) {
    const Contact c = contact_of(fs[i]);
    const double hp = pair_thickness(c);
    const Vec3& p0 = x0_[c.v[0]];
    const Vec3& p1 = x0_[c.v[1]];
    const Vec3& p2 = x0_[c.v[2]];
    const Vec3& p3 = x0_[c.v[3]];
    {
      // Cheap rejection: the two features' boxes at x0 farther apart than the thickness on some axis.
      Aabb ba, bb;
      ba.grow(p0);
      (fs[i].type == 0 ? bb : ba).grow(p1);
      bb.grow(p2), bb.grow(p3);
      if (!ba.overlaps_within(bb, hp)) {
        fs[i].d0 = lower_float(ba.gap(bb));  // the largest axis gap of the boxes: below the distance
        return;
      }
    }
    double w[4];
    double d2;
    Vec3 fallback;
    if (fs[i].type == 0) {
      const PointTriangleClosest r = point_triangle_closest(p0, p1, p2, p3);
      d2 = r.distance_squared;
      w[0] = 1.0, w[1] = -r.weights[0], w[2] = -r.weights[1], w[3] = -r.weights[2];
      fallback = (p2 - p1).cross(p3 - p1);
    } else {
      const SegmentSegmentClosest r = segment_segment_closest(p0, p1, p2, p3);
      d2 = r.distance_squared;
      w[0] = 1.0 - r.s, w[1] = r.s, w[2] = -(1.0 - r.t), w[3] = -r.t;
      fallback = (p1 - p0).cross(p3 - p2);
    }
    const double d = std::sqrt(d2);
    fs[i].d0 = lower_float(d);
    if (!(d2 < hp * hp)) return;
    Vec3 diff = Vec3::Zero(), vrel = Vec3::Zero();
    double im_k[4], beta[4];
    for (int k = 0; k < 4; ++k) {
      diff += w[k] * x0_[c.v[k]];
      vrel += w[k] * (x1_[c.v[k]] - x0_[c.v[k]]) / h_;
      im_k[k] = w_[c.v[k]];
    }
    if (!capped_shares(w, im_k, fs[i].type == 0 ? 1 : 2, settings_.max_share, beta)) return;
    Vec3 nrm;
    if (!contact_normal(diff, fallback, vrel, nrm)) return;
    const double vn = vrel.dot(nrm);
    const double target = settings_.repulsion * (hp - d) / h_;  // m/s
    if (!(vn < target)) return;
    const double dvn = target - vn;
    const double mu_k = pair_mu_k_[c.cloth_a * num_cloths_ + c.cloth_b];
    const double mu_s = pair_mu_s_[c.cloth_a * num_cloths_ + c.cloth_b];
    const Vec3 vt = vrel - vn * nrm;
    const double vtn = vt.norm();
    Vec3 dv = dvn * nrm;
    if (vtn <= mu_s * dvn) {
      dv -= vt;  // static friction: the tangential relative motion stops
    } else if (vtn > 0.0) {
      dv -= (mu_k * dvn / vtn) * vt;  // kinetic: reduced by mu * dvn, never reversed (vtn > mu_s dvn >= ...)
    }
    Impulse& im = out.emplace_back();
    im.active = true;
    for (int k = 0; k < 4; ++k) im.v[k] = c.v[k], im.dv[k] = beta[k] * dv;
  });
  contacts_ += static_cast<long>(imp.size());
  apply_impulses(imp, h_, x1_, &moved);
}

// The first continuous pass's features from the proximity phase's `fs` (I-Cloth's incremental sets): the
// features of triangle pairs with no vertex moved by proximity impulses are unchanged (same boxes, same
// features); those of pairs touching a moved vertex are dropped and found again from the refitted trees
// (triangle_pairs_touching, not culled). A feature belongs to one pair only (its owner pair, see features()).
void SelfCollisionStage::first_pass_features(std::vector<Feature>& fs, const std::vector<char>& moved,
                                             int threads) {
  if (std::none_of(moved.begin(), moved.end(), [](char m) { return m != 0; })) return;
  update_bvhs(threads, false);
  std::vector<char> td(tris_.size(), 0);  // triangles with a moved vertex
  for (int v = 0; v < static_cast<int>(moved.size()); ++v)
    if (moved[v])
      for (int k = vtx_tri_start_[v]; k < vtx_tri_start_[v + 1]; ++k) td[vtx_tri_[k]] = 1;
  fs.erase(std::remove_if(fs.begin(), fs.end(),
                          [&](const Feature& f) {
                            return f.type == 0 ? td[vtx_tri_[vtx_tri_start_[f.a]]] || td[f.b]
                                               : td[edge_owner_[f.a]] || td[edge_owner_[f.b]];
                          }),
           fs.end());
  const std::vector<Feature> redo = features(triangle_pairs_touching(moved, threads), nullptr, threads);
  fs.insert(fs.end(), redo.begin(), redo.end());
}

}  // namespace loom::collision
