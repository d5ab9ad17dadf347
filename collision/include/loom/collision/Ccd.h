#pragma once
// Continuous collision detection for the two elementary pairs of cloth: vertex-face (VF) and edge-edge (EE),
// each vertex moving linearly over the step, t in [0, 1]. The test is CONSERVATIVE: it never misses a contact
// (a pair that comes within `min_separation` at some t is always reported); it may report a pair that only
// comes within `tolerance` of that (a false positive).
//
// Method: inclusion-based root finding over the parameter box (t, u, v) in [0,1]^3 (Snyder 1992, "Interval
// analysis for computer graphics"; the multilinear vertex bound as in Wang et al. 2021, "A Large-Scale
// Benchmark and an Inclusion-Based Algorithm for Continuous Collision Detection", Sec. 4). Why it is
// conservative, in full in Ccd.cpp: F(t,u,v) = (point on primitive A) - (point on primitive B) is multilinear
// in (t, u, v), so over any box its exact range per axis is spanned by its 8 corner values; the corners are
// evaluated in double with an a-priori rounding-error bound (Higham 2002, Lemma 3.4 / Sec. 3.1) added to the
// rejection threshold; a box is only discarded when a whole axis of F provably stays farther than
// min_separation from 0.
#include "loom/cloth/Types.h"

namespace loom::collision {

using loom::cloth::Vec3;

struct CcdOptions {
  double min_separation =
      0.0;                  // m; a pair closer than this (per axis, so also in Euclidean norm) is a contact
  double tolerance = 1e-6;  // 1; relative to the query's extent: a box whose image is narrower is a hit
  double toi_tolerance = 1e-4;  // 1; after the first hit, the time of impact is refined to this width in t
  long toi_max_boxes = 1024;    // 1; boxes spent refining the time of impact after the first hit
  long max_boxes =
      1L << 18;  // 1; inclusion boxes per query; an exhausted budget reports a hit (conservative)
};

struct CcdResult {
  bool hit = false;               // the primitives may come within min_separation (never false when they do)
  double toi = 1.0;               // 1; lower bound on the first contact time in [0, 1] (1 when !hit)
  long boxes = 0;                 // inclusion boxes evaluated
  bool budget_exhausted = false;  // hit was reported because max_boxes ran out
};

// Vertex p against triangle (a, b, c); suffix 0 = start of step, 1 = end of step.
CcdResult vertex_face_ccd(const Vec3& p0, const Vec3& a0, const Vec3& b0, const Vec3& c0, const Vec3& p1,
                          const Vec3& a1, const Vec3& b1, const Vec3& c1, const CcdOptions& options = {});

// Edge (ea0, ea1) against edge (eb0, eb1); suffix t0 = start of step, t1 = end of step.
CcdResult edge_edge_ccd(const Vec3& ea0_t0, const Vec3& ea1_t0, const Vec3& eb0_t0, const Vec3& eb1_t0,
                        const Vec3& ea0_t1, const Vec3& ea1_t1, const Vec3& eb0_t1, const Vec3& eb1_t1,
                        const CcdOptions& options = {});

}  // namespace loom::collision
