// Self-collision continuous passes (SelfCollisionStage.h, step 3): CCD of every feature on x0 -> x1 with
// inelastic impulses on the hits (Bridson, Fedkiw & Anderson 2002, Sec. 7.4).
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

// Continuous test of every feature on x0 -> x1 with minimum separation; hits approaching along the contact
// normal at the time of impact get the inelastic impulse that cancels the approach (Bridson 2002, Sec. 7.4).
bool SelfCollisionStage::ccd_pass(const std::vector<Feature>& fs, int threads, std::vector<char>& dirty) {
  PhaseTimer timer(ccd_ms_);
  const long n = static_cast<long>(fs.size());
  long tests = 0, boxes = 0, start_hits = 0;
  // Every hit is recorded (its vertices are retested next pass); `active` when it gives an impulse.
  const std::vector<Impulse> imp = collect_impulses(n, threads, [&](long i, std::vector<Impulse>& out) {
    const Contact c = contact_of(fs[i]);
    const Vec3 *a0[4], *a1[4];
    for (int k = 0; k < 4; ++k) a0[k] = &x0_[c.v[k]], a1[k] = &x1_[c.v[k]];
    // Cheap rejection: swept boxes farther apart than the separation on some axis.
    const double sep = settings_.separation * pair_thickness(c);
    Aabb ba, bb;
    const int split = fs[i].type == 0 ? 1 : 2;
    for (int k = 0; k < 4; ++k) (k < split ? ba : bb).grow(*a0[k]), (k < split ? ba : bb).grow(*a1[k]);
    ba.lo.array() -= sep, ba.hi.array() += sep;
    if (!ba.overlaps(bb)) return;
    // Cheap rejection 2: distance at t = 0 minus how much it can shrink during the step. For points moving
    // linearly, the distance between the two features changes by at most the largest relative displacement
    // |dx_i - dx_j| over one vertex i of the first feature and one vertex j of the second (a point of either
    // feature is a fixed convex combination of its vertices), so d(0) > sep + that bound proves d(t) > sep
    // on the whole step: the continuous test could only find a false positive.
    bool at_start = false;  // closer than the separation at t = 0 already
    {
      Vec3 dx[4];
      for (int k = 0; k < 4; ++k) dx[k] = *a1[k] - *a0[k];
      double reach2 = 0.0;
      for (int k = 0; k < split; ++k)
        for (int m = split; m < 4; ++m) reach2 = std::max(reach2, (dx[k] - dx[m]).squaredNorm());
      const double bound = (sep + std::sqrt(reach2)) * (1.0 + 1e-9);
      if (fs[i].d0 > bound) return;  // the proximity phase's lower bound on d(0) already proves it
      const double d0 = std::sqrt(
          fs[i].type == 0 ? point_triangle_closest(*a0[0], *a0[1], *a0[2], *a0[3]).distance_squared
                          : segment_segment_closest(*a0[0], *a0[1], *a0[2], *a0[3]).distance_squared);
      if (d0 > bound) return;
      at_start = d0 <= sep;
    }
    // A pair closer than the separation at the step's start is a contact at t = 0: reported as a hit with
    // time of impact 0 without the continuous test, whose answer could only be a hit with a time of impact
    // near 0, found after refining its boxes down to the tolerance (a hit cost 200-270 boxes, a miss 8, on
    // the Sphere at 50k triangles). A hit is always allowed (conservative), so nothing can be missed this
    // way.
    CcdResult r;
    if (at_start) {
      r.hit = true;
      r.toi = 0.0;
#pragma omp atomic
      ++start_hits;
    } else {
      CcdOptions opt;
      opt.min_separation = sep;
      opt.tolerance = 1e-4;      // of the query's extent: a few micrometres at cloth scale, well below sep
      opt.toi_tolerance = 1e-2;  // the time of impact only places the contact normal
      opt.toi_max_boxes = 64;
      r = fs[i].type == 0
              ? vertex_face_ccd(*a0[0], *a0[1], *a0[2], *a0[3], *a1[0], *a1[1], *a1[2], *a1[3], opt)
              : edge_edge_ccd(*a0[0], *a0[1], *a0[2], *a0[3], *a1[0], *a1[1], *a1[2], *a1[3], opt);
#pragma omp atomic
      ++tests;
#pragma omp atomic
      boxes += r.boxes;
    }
    if (!r.hit) return;
    Impulse& im = out.emplace_back();
    for (int k = 0; k < 4; ++k) im.v[k] = c.v[k];
    Vec3 q[4];
    for (int k = 0; k < 4; ++k) q[k] = *a0[k] + r.toi * (*a1[k] - *a0[k]);
    double w[4];
    Vec3 fallback;
    if (fs[i].type == 0) {
      const PointTriangleClosest cl = point_triangle_closest(q[0], q[1], q[2], q[3]);
      w[0] = 1.0, w[1] = -cl.weights[0], w[2] = -cl.weights[1], w[3] = -cl.weights[2];
      fallback = (q[2] - q[1]).cross(q[3] - q[1]);
    } else {
      const SegmentSegmentClosest cl = segment_segment_closest(q[0], q[1], q[2], q[3]);
      w[0] = 1.0 - cl.s, w[1] = cl.s, w[2] = -(1.0 - cl.t), w[3] = -cl.t;
      fallback = (q[1] - q[0]).cross(q[3] - q[2]);
    }
    Vec3 diff = Vec3::Zero(), side = Vec3::Zero(), vrel = Vec3::Zero();
    double im_k[4], beta[4];
    for (int k = 0; k < 4; ++k) {
      diff += w[k] * q[k];
      side += w[k] * *a0[k];
      vrel += w[k] * (*a1[k] - *a0[k]) / h_;
      im_k[k] = w_[c.v[k]];
    }
    if (!capped_shares(w, im_k, fs[i].type == 0 ? 1 : 2, settings_.max_share, beta)) return;
    Vec3 nrm;
    if (!contact_normal(diff, fallback, side, nrm)) return;
    const double vn = vrel.dot(nrm);
    if (!(vn < 0.0)) return;
    im.active = true;
    const Vec3 dv = -vn * nrm;
    for (int k = 0; k < 4; ++k) im.dv[k] = beta[k] * dv;
  });
  ccd_tests_ += tests;
  ccd_boxes_ += boxes;
  ccd_start_hits_ += start_hits;
  std::fill(dirty.begin(), dirty.end(), 0);
  for (const Impulse& im : imp) {
    contacts_ += im.active;
    for (int k = 0; k < 4; ++k) dirty[im.v[k]] = 1;  // retested next pass even if not moved
  }
  apply_impulses(imp, h_, x1_, &dirty);
  return !imp.empty();
}

}  // namespace loom::collision
