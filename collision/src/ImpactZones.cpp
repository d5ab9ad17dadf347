// Self-collision fail-safe (SelfCollisionStage.h, step 4): impact zones, Harmon et al. 2008 inelastic
// projection and Provot 1997 rigid zones.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>

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

// Provot 1997 rigid impact zone: velocities (x1 - x0) / h of the zone's vertices replaced by the rigid motion
// with the same linear and angular momentum about the centre of mass at x0 (linearised rotation).
// With kinematic (pinned) vertices: those keep their end positions; the others follow the pinned vertices'
// best-fit rotation and translation (Kabsch 1976), translation only when fewer than three non-collinear
// pinned vertices leave the rotation undetermined. That case is not guaranteed.
void SelfCollisionStage::apply_rigid_zone(const std::vector<int>& verts_in) {
  std::vector<int> pinned, free;
  for (int v : verts_in) {
    if (fixed_[v])
      fixed_[v] = 0, w_[v] = w_free_[v];  // held for a collider: moves with the zone, checked again
    (w_[v] == 0.0 ? pinned : free).push_back(v);
  }
  if (!pinned.empty()) {
    Vec3 c0 = Vec3::Zero(), c1 = Vec3::Zero();
    for (int v : pinned) c0 += x0_[v], c1 += x1_[v];
    c0 /= static_cast<double>(pinned.size()), c1 /= static_cast<double>(pinned.size());
    Mat3 R = Mat3::Identity();
    if (pinned.size() >= 3) {
      Mat3 H = Mat3::Zero();
      for (int v : pinned) H += (x0_[v] - c0) * (x1_[v] - c1).transpose();
      Eigen::JacobiSVD<Mat3> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Mat3 D = Mat3::Identity();
      if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0) D(2, 2) = -1.0;
      const Eigen::Vector3d sv = svd.singularValues();
      if (sv[1] > 1e-9 * sv[0]) R = svd.matrixV() * D * svd.matrixU().transpose();
    }
    for (int v : free) x1_[v] = c1 + R * (x0_[v] - c0);
    return;
  }
  const std::vector<int>& verts = free;
  {
    double mass = 0.0;
    Vec3 xc = Vec3::Zero(), vc = Vec3::Zero();
    for (int v : verts) {
      mass += m_[v];
      xc += m_[v] * x0_[v];
      vc += m_[v] * (x1_[v] - x0_[v]) / h_;
    }
    if (!(mass > 0.0)) return;
    xc /= mass, vc /= mass;
    Vec3 L = Vec3::Zero();
    Mat3 I = Mat3::Zero();
    for (int v : verts) {
      const Vec3 r = x0_[v] - xc;
      L += m_[v] * r.cross((x1_[v] - x0_[v]) / h_ - vc);
      I += m_[v] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
    }
    const Vec3 omega = I.completeOrthogonalDecomposition().solve(L);
    for (int v : verts) x1_[v] = x0_[v] + h_ * (vc + omega.cross(x0_[v] - xc));
  }
}

// Harmon, Vouga, Tamstorf, Grinspun 2008, "Robust treatment of simultaneous collisions", Sec. 4 (inelastic
// projection): the zone's end positions x1 are changed as little as possible in the mass metric,
//   min sum_k m_k |x1'_k - x1_k|^2  s.t.  n_c . sum_i w_ci x1'_ci >= b_c  for every contact c of the zone,
// (the relative position along the contact normal at the end of the step at least a small gap past the one at
// the time of impact), which cancels the approach along the normals but keeps tangential (sliding) motion.
// Solved by projected Gauss-Seidel on the multipliers (lambda_c >= 0) in constraint order, so the result does
// not depend on the thread count. Kinematic vertices (inverse mass 0) do not move. Returns false if it did
// not converge (the constraints can be infeasible, e.g. a layer squeezed between two others); the caller then
// restores the zone and moves it rigidly.
bool SelfCollisionStage::project_zone(const std::vector<int>& constraints) {
  const int nc = static_cast<int>(constraints.size());
  std::vector<double> lambda(nc, 0.0), denom(nc, 0.0);
  for (int k = 0; k < nc; ++k) {
    const ZoneConstraint& c = zone_constraints_[constraints[k]];
    for (int i = 0; i < 4; ++i) denom[k] += c.w[i] * c.w[i] * w_[c.v[i]];
  }
  for (int it = 0; it < 200; ++it) {
    double worst = 0.0;
    for (int k = 0; k < nc; ++k) {
      if (!(denom[k] > 0.0)) continue;
      const ZoneConstraint& c = zone_constraints_[constraints[k]];
      double g = -c.b;
      for (int i = 0; i < 4; ++i) g += c.w[i] * c.n.dot(x1_[c.v[i]]);
      const double dl = std::max(-lambda[k], -g / denom[k]);
      if (dl == 0.0) continue;
      lambda[k] += dl;
      for (int i = 0; i < 4; ++i) x1_[c.v[i]] += (dl * c.w[i] * w_[c.v[i]]) * c.n;
      worst = std::max(worst, std::abs(dl) * denom[k]);
    }
    if (worst < 1e-10) return true;  // m: every constraint met to 0.1 nm
  }
  return false;
}

namespace {

constexpr int kProjections = 4;  // inelastic projections of a zone before it moves rigidly

}  // namespace

// Impact-zone fail-safe: test pairs touching `dirty` vertices (continuous, separation 0); vertices of hits
// are merged into zones (union-find); every changed zone is first handled by inelastic projection over all
// the contacts it has collected this step (project_zone); a zone that still collides after `kProjections`
// projections, or that merges with a rigid one, moves rigidly from then on (Provot's rigid impact zone, the
// last resort, apply_rigid_zone). Repeat until no hit. Pairs inside one rigid zone are skipped (it moves
// affinely from its intersection-free start). Returns false if the iteration cap forced one global zone.
bool SelfCollisionStage::impact_zones(std::vector<char> dirty, int threads) {
  PhaseTimer timer(zones_ms_);
  const int nv = static_cast<int>(x0_.size());
  zone_parent_.assign(nv, -1);
  zone_constraints_.clear();
  std::vector<int> zone_rounds(nv, 0);  // per root: rounds done (> kProjections: moved rigidly)
  const double budget = settings_.zone_features_per_vertex * nv;
  double tested = 0.0;
  for (int it = 0; it < settings_.max_zone_iterations; ++it) {
    if (std::none_of(dirty.begin(), dirty.end(), [](char d) { return d != 0; })) return true;
    update_bvhs(threads, false);
    const std::vector<Feature> fs = features(triangle_pairs_touching(dirty, threads), &dirty, threads);
    const long n = static_cast<long>(fs.size());
    tested += static_cast<double>(n);
    if (tested > budget) {
      char why[256];
      std::snprintf(
          why, sizeof why,
          "self-collision: the impact zones tested %.3g vertex-face and edge-edge features in one step, "
          "more than %.3g per cloth vertex (the cloth is torn apart or crushed); every vertex was "
          "moved as one rigid zone",
          tested, settings_.zone_features_per_vertex);
      zone_budget_violation_ = why;
      break;
    }
    std::vector<char> hit(n, 0);
    std::vector<ZoneConstraint> found(n);
    zone_hits(fs, zone_rounds, threads, hit, found);
    std::vector<int> roots_changed;
    const bool any = merge_zone_hits(fs, hit, found, zone_rounds, roots_changed);
    std::fill(dirty.begin(), dirty.end(), 0);
    if (!any) return true;
    ++zone_iterations_;
    move_changed_zones(roots_changed, zone_rounds, dirty);
  }
  // Last resort: everything moves as one rigid zone (Provot 1997: from an intersection-free start, the
  // linearised rigid motion is an invertible affine map at every t).
  std::vector<int> all(nv);
  for (int v = 0; v < nv; ++v) all[v] = v;
  apply_rigid_zone(all);
  ++unresolved_;
  return false;
}

// The continuous test (separation 0) of every feature of `fs` on x0 -> x1: hit[i] = 1 for a hit, found[i]
// its constraint (n = 0: no usable normal, the zone will have to go rigid). Pairs inside one rigid zone
// (more than kProjections rounds) are skipped.
void SelfCollisionStage::zone_hits(const std::vector<Feature>& fs, const std::vector<int>& zone_rounds,
                                   int threads, std::vector<char>& hit, std::vector<ZoneConstraint>& found) {
  auto root_of = [&](int v) {
    while (zone_parent_[v] != v) v = zone_parent_[v];
    return v;
  };
  const long n = static_cast<long>(fs.size());
  // A query that has not settled after kZoneCcdBoxes boxes is a hit (conservative: the zone gets one
  // constraint more). Features crushed flat against each other, just outside the separation over a whole
  // patch, would otherwise refine that patch at the 1e-6 tolerance to the default budget of 2^18 boxes.
  CcdOptions opt;
  opt.toi_tolerance = 1e-2;
  opt.toi_max_boxes = 32;
  opt.max_boxes = kZoneCcdBoxes;
  long cut = 0;
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(dynamic, 256) reduction(+ : cut)
  for (long i = 0; i < n; ++i) {
    const Contact c = contact_of(fs[i]);
    // Pairs inside one rigid zone move affinely with it and stay apart.
    if (zone_parent_[c.v[0]] >= 0) {
      const int r = root_of(c.v[0]);
      bool same = zone_rounds[r] > kProjections;
      for (int k = 1; k < 4 && same; ++k) same = zone_parent_[c.v[k]] >= 0 && root_of(c.v[k]) == r;
      if (same) continue;
    }
    const Vec3 *a0[4], *a1[4];
    for (int k = 0; k < 4; ++k) a0[k] = &x0_[c.v[k]], a1[k] = &x1_[c.v[k]];
    Aabb ba, bb;
    const int split = fs[i].type == 0 ? 1 : 2;
    for (int k = 0; k < 4; ++k) (k < split ? ba : bb).grow(*a0[k]), (k < split ? ba : bb).grow(*a1[k]);
    if (!ba.overlaps(bb)) continue;
    const CcdResult r =
        fs[i].type == 0 ? vertex_face_ccd(*a0[0], *a0[1], *a0[2], *a0[3], *a1[0], *a1[1], *a1[2], *a1[3], opt)
                        : edge_edge_ccd(*a0[0], *a0[1], *a0[2], *a0[3], *a1[0], *a1[1], *a1[2], *a1[3], opt);
    cut += r.budget_exhausted;
    if (!r.hit) continue;
    hit[i] = 1;
    // The constraint of this contact: normal and weights at the time of impact; the gap to keep at the end
    // of the step is a tenth of the pair thickness past the relative position at the time of impact.
    Vec3 q[4];
    for (int k = 0; k < 4; ++k) q[k] = *a0[k] + r.toi * (*a1[k] - *a0[k]);
    ZoneConstraint& zc = found[i];
    Vec3 fallback;
    if (fs[i].type == 0) {
      const PointTriangleClosest cl = point_triangle_closest(q[0], q[1], q[2], q[3]);
      zc.w[0] = 1.0, zc.w[1] = -cl.weights[0], zc.w[2] = -cl.weights[1], zc.w[3] = -cl.weights[2];
      fallback = (q[2] - q[1]).cross(q[3] - q[1]);
    } else {
      const SegmentSegmentClosest cl = segment_segment_closest(q[0], q[1], q[2], q[3]);
      zc.w[0] = 1.0 - cl.s, zc.w[1] = cl.s, zc.w[2] = -(1.0 - cl.t), zc.w[3] = -cl.t;
      fallback = (q[1] - q[0]).cross(q[3] - q[2]);
    }
    Vec3 diff = Vec3::Zero(), side = Vec3::Zero();
    for (int k = 0; k < 4; ++k) diff += zc.w[k] * q[k], side += zc.w[k] * *a0[k];
    for (int k = 0; k < 4; ++k) zc.v[k] = c.v[k];
    if (!contact_normal(diff, fallback, side, zc.n)) {
      zc.n = Vec3::Zero();  // no usable normal: the zone will have to go rigid
      continue;
    }
    zc.b = zc.n.dot(diff) + 0.1 * pair_thickness(c);
  }
  zone_ccd_cut_ += cut;
}

// Merges the vertices of every hit into zones (serial, in feature order) and keeps the hits' constraints
// (zone_constraints_); a hit without a normal sends its zone to the rigid rounds. `roots_changed`: one
// vertex of every zone a hit touched. Returns whether there was any hit.
bool SelfCollisionStage::merge_zone_hits(const std::vector<Feature>& fs, const std::vector<char>& hit,
                                         const std::vector<ZoneConstraint>& found,
                                         std::vector<int>& zone_rounds, std::vector<int>& roots_changed) {
  const long n = static_cast<long>(fs.size());
  bool any = false;
  for (long i = 0; i < n; ++i) {
    if (!hit[i]) continue;
    any = true;
    const Contact c = contact_of(fs[i]);
    for (int k = 0; k < 4; ++k)
      if (zone_parent_[c.v[k]] < 0) zone_parent_[c.v[k]] = c.v[k], ++impact_zones_;
    for (int k = 1; k < 4; ++k) {
      const int a = find_root(zone_parent_, c.v[0]), b = find_root(zone_parent_, c.v[k]);
      if (a != b) {
        const int lo = std::min(a, b), hi = std::max(a, b);
        zone_parent_[hi] = lo, --impact_zones_;
        zone_rounds[lo] = std::max(zone_rounds[lo], zone_rounds[hi]);
      }
    }
    if (found[i].n.isZero(0.0)) {
      zone_rounds[find_root(zone_parent_, c.v[0])] = kProjections;
    } else {
      zone_constraints_.push_back(found[i]);
    }
    roots_changed.push_back(c.v[0]);
  }
  return any;
}

// Every zone a hit touched this round: inelastic projection over its constraints while it has had fewer than
// kProjections rounds (restored and sent rigid when the projection fails), else the rigid zone. Its vertices
// are marked in `dirty` for the next round's tests.
void SelfCollisionStage::move_changed_zones(const std::vector<int>& roots_changed,
                                            std::vector<int>& zone_rounds, std::vector<char>& dirty) {
  const int nv = static_cast<int>(x0_.size());
  std::vector<char> root_mark(nv, 0);
  for (int v : roots_changed) root_mark[find_root(zone_parent_, v)] = 1;
  std::vector<std::vector<int>> zones, constraints;
  std::vector<int> zone_index(nv, -1);
  for (int v = 0; v < nv; ++v) {
    if (zone_parent_[v] < 0) continue;
    const int r = find_root(zone_parent_, v);
    if (!root_mark[r]) continue;
    if (zone_index[r] < 0)
      zone_index[r] = static_cast<int>(zones.size()), zones.emplace_back(), constraints.emplace_back();
    zones[zone_index[r]].push_back(v);
  }
  for (int k = 0; k < static_cast<int>(zone_constraints_.size()); ++k) {
    const int z = zone_index[find_root(zone_parent_, zone_constraints_[k].v[0])];
    if (z >= 0) constraints[z].push_back(k);
  }
  for (size_t z = 0; z < zones.size(); ++z) {
    int& rounds = zone_rounds[find_root(zone_parent_, zones[z][0])];
    bool done = false;
    if (rounds < kProjections) {
      std::vector<Vec3> saved(zones[z].size());
      for (size_t k = 0; k < zones[z].size(); ++k) saved[k] = x1_[zones[z][k]];
      ++projections_;
      done = project_zone(constraints[z]);
      if (!done) {
        for (size_t k = 0; k < zones[z].size(); ++k) x1_[zones[z][k]] = saved[k];
        rounds = kProjections;  // not solvable by projection: rigid now
      }
    }
    if (!done) {
      if (rounds == kProjections) ++rigid_zones_;
      apply_rigid_zone(zones[z]);
    }
    ++rounds;
    for (int v : zones[z]) dirty[v] = 1;
  }
}

}  // namespace loom::collision
