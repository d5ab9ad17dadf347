// Conservative vertex-face / edge-edge CCD by inclusion over (t, u, v). See Ccd.h for the contract.
//
// WHY IT NEVER MISSES A CONTACT (the argument the code relies on, step by step):
//
// 1. Parametrisation. With q(t) = q0 + t (q1 - q0) for every vertex q:
//      VF: F(t,u,v) = p(t) - [(1-u-v) a(t) + u b(t) + v c(t)],      (t,u,v) in [0,1]^3, u + v <= 1
//      EE: F(t,u,v) = [(1-u) a0(t) + u a1(t)] - [(1-v) b0(t) + v b1(t)], (t,u,v) in [0,1]^3
//    The pair is in contact (within distance s = min_separation) iff some admissible (t,u,v) has |F| <= s
//    (Euclidean), which implies |F_k| <= s on every axis k. We only ever discard a box when some axis has
//    F_k > s or F_k < -s on the whole box, so no admissible point with |F| <= s is ever discarded.
// 2. Exact range over a box. Each F_k has degree <= 1 in each of t, u, v separately (multilinear). A
//    multilinear function restricted to a box is, along every coordinate line, affine, so its min and max
//    over the box are attained at box corners: range_k(box) = [min over 8 corners, max over 8 corners]
//    exactly. For VF, a box that is only partly inside u + v <= 1 is evaluated over the whole box: a
//    superset, safe. A box with u_lo + v_lo > 1 holds no admissible point (fl(u_lo + v_lo) > 1 implies u_lo +
//    v_lo > 1, because rounding is monotone and 1 is a double).
// 3. Rounding. The corners are evaluated in double in the order written in eval_corner(). By the standard
//    model (Higham, "Accuracy and Stability of Numerical Algorithms", 2002, Sec. 3.1 and Lemma 3.4), the
//    computed value equals sum_i m_i * prod_{j<=k_i} (1 + d_ij), |d_ij| <= u = 2^-53, where m_i are the
//    monomials of the exact expression and k_i <= 10 is the number of operations on the path of m_i (counted
//    below, even if 1-u, 1-u-v happened to round). Hence |computed - exact| <= gamma_10 * sum_i |m_i|,
//    gamma_10 = 10u / (1 - 10u). With M_k = max |coordinate k| over the 8 input points and t,u,v in [0,1]:
//    the monomials of q(t) = q0 + t (q1 - q0) sum to <= |q0| + t|q1| + t|q0| <= 3 M_k, and the weights,
//    expanded into monomials (1, u, v are not assumed to cancel), sum to 1 + (1 + u + v) + u + v <= 6 (VF)
//    and (1 + u) + u + (1 + v) + v <= 6 (EE), so sum_i |m_i| <= 18 M_k and the error is below 18 * 10.0001 u
//    M_k < 256 u M_k = err_k. Underflow adds at most 2^-1074 per multiplication (additions of subnormals are
//    exact); kUnderflowPad covers it. FMA contraction, if the compiler uses it, only removes roundings, so
//    the bound still holds. No -ffast-math (the build does not use it).
// 4. Rejection rule: discard the box when min_corner(F_k) > thr_k or max_corner(F_k) < -thr_k with
//    thr_k >= s + err_k (computed with an upward margin). Then every exact corner value, hence (2.) every
//    exact value on the box, is beyond s on axis k: no contact in the box.
// 5. Every box that is not discarded is either split (its halves cover it) or accepted as a hit (when its
//    image is narrower than the tolerance, when it cannot be split further, or when the box budget is spent).
//    So a contact point always lies in a box that is split or accepted: the answer is never a false "no".
// 6. A second rejection along a normal direction (separated_along_normal) uses the same argument; see there.
#include "loom/collision/Ccd.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace loom::collision {
namespace {

constexpr double kErrFactor = 0x1p-45;       // 256 u, u = 2^-53 (see 3.)
constexpr double kUnderflowPad = 0x1p-1060;  // >= 12 * 2^-1074, absolute error from gradual underflow
constexpr double kMinWidth = 0x1p-40;        // parameter boxes are not split below this width (dyadic, exact)

struct Box {
  double lo[3];  // t, u, v lower bounds
  double hi[3];  // t, u, v upper bounds
};

// One query, in arrays the hot loop reads: q0[i][k] start position of point i on axis k, dq = q1 - q0.
struct Query {
  bool vf = true;
  double q0[4][3];
  double dq[4][3];
  double thr[3];   // m; s + err_k, rounded upward
  double tol = 0;  // m; absolute image-width tolerance
};

// F_k at parameter corner (t, u, v), in the exact order the error bound of (3.) counts.
inline double eval_corner(const Query& q, int k, double t, double u, double v) {
  const double x0 = q.q0[0][k] + t * q.dq[0][k];
  const double x1 = q.q0[1][k] + t * q.dq[1][k];
  const double x2 = q.q0[2][k] + t * q.dq[2][k];
  const double x3 = q.q0[3][k] + t * q.dq[3][k];
  if (q.vf) {
    const double w = (1.0 - u) - v;
    return ((x0 - w * x1) - u * x2) - v * x3;
  }
  return (((1.0 - u) * x0 + u * x1) - (1.0 - v) * x2) - v * x3;
}

Query make_query(bool vf, const Vec3* p0, const Vec3* p1, const CcdOptions& o) {
  Query q;
  q.vf = vf;
  double extent = 0;
  for (int k = 0; k < 3; ++k) {
    double m = 0, lo = p0[0][k], hi = p0[0][k];
    for (int i = 0; i < 4; ++i) {
      q.q0[i][k] = p0[i][k];
      q.dq[i][k] = p1[i][k] - p0[i][k];
      m = std::max({m, std::abs(p0[i][k]), std::abs(p1[i][k])});
      lo = std::min({lo, p0[i][k], p1[i][k]});
      hi = std::max({hi, p0[i][k], p1[i][k]});
    }
    const double err = m * kErrFactor + kUnderflowPad;
    // fl(fl(s + err) * (1 + 4u)) >= (s + err)(1 - u)^2 (1 + 4u) >= s + err.
    q.thr[k] = (o.min_separation + err) * (1.0 + 0x1p-51);
    extent = std::max(extent, hi - lo);
  }
  q.tol = o.tolerance * extent;
  return q;
}

// (6.) The same rejection along one more direction n: the normal of the triangle (VF) or the cross product of
// the edges (EE) at the box's mid time. Any fixed double vector n is valid, so n needs no accuracy; g = n . F
// is multilinear (n is constant), so its range is spanned by the corners. With F^_k the computed corners and
// e_k = thr_k - s their error bound: |fl(n . F^) - n . F| <= sum_k |n_k| e_k + gamma_3 sum_k |n_k| |F^_k|
// (Higham 2002, Sec. 3.1), and a contact (|F| <= s) has |n . F| <= |n|_2 s <= |n|_1 s. The bound B below is
// computed with an upward margin (1 + 2^-40) that covers the few roundings of its own evaluation.
bool separated_along_normal(const Query& q, const Box& b, const double (&f)[3][8]) {
  const double tm = 0.5 * (b.lo[0] + b.hi[0]);
  double x[4][3];
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) x[i][k] = q.q0[i][k] + tm * q.dq[i][k];
  double d1[3], d2[3];
  for (int k = 0; k < 3; ++k) {
    d1[k] = q.vf ? x[2][k] - x[1][k] : x[1][k] - x[0][k];
    d2[k] = q.vf ? x[3][k] - x[1][k] : x[3][k] - x[2][k];
  }
  double n[3] = {d1[1] * d2[2] - d1[2] * d2[1], d1[2] * d2[0] - d1[0] * d2[2], d1[0] * d2[1] - d1[1] * d2[0]};
  const double scale = std::max({std::abs(n[0]), std::abs(n[1]), std::abs(n[2])});
  if (!(scale > 0) || !std::isfinite(scale)) return false;
  for (double& c : n) c /= scale;  // |n_k| <= 1; still just some fixed vector
  double mn = HUGE_VAL, mx = -HUGE_VAL, mag = 0;
  for (int c = 0; c < 8; ++c) {
    const double g = (n[0] * f[0][c] + n[1] * f[1][c]) + n[2] * f[2][c];
    mn = std::min(mn, g);
    mx = std::max(mx, g);
    mag = std::max(mag, std::abs(n[0] * f[0][c]) + std::abs(n[1] * f[1][c]) + std::abs(n[2] * f[2][c]));
  }
  double bound = 0x1p-50 * mag;  // >= gamma_3 sum |n_k| |F^_k| (8u > gamma_3)
  for (int k = 0; k < 3; ++k) bound += std::abs(n[k]) * q.thr[k];  // thr_k >= s + e_k
  bound *= 1.0 + 0x1p-40;
  return mn > bound || mx < -bound;
}

CcdResult solve(const Query& q, const CcdOptions& o) {
  CcdResult r;
  std::vector<Box> stack;
  stack.reserve(64);
  stack.push_back(Box{{0, 0, 0}, {1, 1, 1}});
  double f[3][8];
  long hit_boxes = 0;  // boxes evaluated when the first hit was found
  while (!stack.empty()) {
    const Box b = stack.back();
    stack.pop_back();
    if (r.hit && b.lo[0] >= r.toi) continue;  // cannot lower the first-contact bound
    if (r.hit &&
        r.boxes >= hit_boxes + o.toi_max_boxes) {  // refinement budget spent: bound from what is left
      r.toi = std::min(r.toi, b.lo[0]);
      for (const Box& s : stack) r.toi = std::min(r.toi, s.lo[0]);
      return r;
    }
    if (q.vf && b.lo[1] + b.lo[2] > 1.0) continue;  // outside the triangle (2.)
    ++r.boxes;
    bool separated = false;
    double width[3];
    for (int k = 0; k < 3 && !separated; ++k) {
      double mn = HUGE_VAL, mx = -HUGE_VAL;
      for (int c = 0; c < 8; ++c) {
        const double t = (c & 1) ? b.hi[0] : b.lo[0];
        const double u = (c & 2) ? b.hi[1] : b.lo[1];
        const double v = (c & 4) ? b.hi[2] : b.lo[2];
        f[k][c] = eval_corner(q, k, t, u, v);
        mn = std::min(mn, f[k][c]);
        mx = std::max(mx, f[k][c]);
      }
      separated = mn > q.thr[k] || mx < -q.thr[k];
      width[k] = mx - mn;
    }
    if (separated || separated_along_normal(q, b, f)) continue;  // (4.), (6.)
    const bool narrow = width[0] <= q.tol && width[1] <= q.tol && width[2] <= q.tol;
    // Split the parameter whose variation moves F the most (largest corner difference along it).
    int split = -1;
    double best = -1;
    for (int d = 0; d < 3; ++d) {
      if (b.hi[d] - b.lo[d] <= kMinWidth) continue;
      const int bit = 1 << d;
      double spread = 0;
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 8; ++c)
          if (!(c & bit)) spread = std::max(spread, std::abs(f[k][c | bit] - f[k][c]));
      if (spread > best) best = spread, split = d;
    }
    const bool exhausted = r.boxes >= o.max_boxes;
    // Once a hit is known, a box only serves to lower the first-contact bound: thin enough in t is enough.
    const bool thin = r.hit && b.hi[0] - b.lo[0] <= o.toi_tolerance;
    if (narrow || thin || split < 0 || exhausted) {  // accept: a hit (5.)
      if (!r.hit) hit_boxes = r.boxes;
      r.hit = true;
      r.toi = std::min(r.toi, b.lo[0]);
      if (exhausted && !narrow && !thin && split >= 0) {
        r.budget_exhausted = true;
        for (const Box& s : stack) r.toi = std::min(r.toi, s.lo[0]);  // every box not yet discarded
        return r;
      }
      continue;  // keep looking for an earlier contact among the boxes that start before r.toi
    }
    const double mid = 0.5 * (b.lo[split] + b.hi[split]);  // exact: dyadic, width > 2^-40
    Box lower = b, upper = b;
    lower.hi[split] = mid;
    upper.lo[split] = mid;
    stack.push_back(upper);  // lower half on top: earlier times are explored first
    stack.push_back(lower);
  }
  return r;
}

}  // namespace

CcdResult vertex_face_ccd(const Vec3& p0, const Vec3& a0, const Vec3& b0, const Vec3& c0, const Vec3& p1,
                          const Vec3& a1, const Vec3& b1, const Vec3& c1, const CcdOptions& options) {
  const Vec3 s[4] = {p0, a0, b0, c0};
  const Vec3 e[4] = {p1, a1, b1, c1};
  return solve(make_query(true, s, e, options), options);
}

CcdResult edge_edge_ccd(const Vec3& ea0_t0, const Vec3& ea1_t0, const Vec3& eb0_t0, const Vec3& eb1_t0,
                        const Vec3& ea0_t1, const Vec3& ea1_t1, const Vec3& eb0_t1, const Vec3& eb1_t1,
                        const CcdOptions& options) {
  const Vec3 s[4] = {ea0_t0, ea1_t0, eb0_t0, eb1_t0};
  const Vec3 e[4] = {ea0_t1, ea1_t1, eb0_t1, eb1_t1};
  return solve(make_query(false, s, e, options), options);
}

}  // namespace loom::collision
