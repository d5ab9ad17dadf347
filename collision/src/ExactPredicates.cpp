// Filtered exact orient3d/orient2d and an exact closed triangle-triangle intersection test
// (ExactPredicates.h).
#include "loom/collision/ExactPredicates.h"

#include <gmpxx.h>

#include <cmath>

namespace loom::collision {
namespace {

constexpr double kEps = 0x1p-53;  // Shewchuk's epsilon (half an ulp of 1)
constexpr double kO3dBound = (7.0 + 56.0 * kEps) * kEps;
constexpr double kO2dBound = (3.0 + 16.0 * kEps) * kEps;

int sign(const mpq_class& x) { return sgn(x); }

int orient3d_exact(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  mpq_class m[3][3];
  const Vec3* r[3] = {&a, &b, &c};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) m[i][k] = mpq_class((*r[i])[k]) - mpq_class(d[k]);
  const mpq_class det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                        m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                        m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  return sign(det);
}

// Does closed segment pq meet closed segment rs? All four points in the plane that drops axis `drop`.
bool segments_meet_2d(const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& s, int drop) {
  const int o1 = orient2d(p, q, r, drop), o2 = orient2d(p, q, s, drop);
  const int o3 = orient2d(r, s, p, drop), o4 = orient2d(r, s, q, drop);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  // Collinear touching: a point of one lies on the other (bounding-box test on the collinear line).
  auto on = [drop](const Vec3& a, const Vec3& b, const Vec3& x) {
    for (int k = 0; k < 3; ++k)
      if (k != drop && (x[k] < std::min(a[k], b[k]) || x[k] > std::max(a[k], b[k]))) return false;
    return true;
  };
  if (o1 == 0 && on(p, q, r)) return true;
  if (o2 == 0 && on(p, q, s)) return true;
  if (o3 == 0 && on(r, s, p)) return true;
  if (o4 == 0 && on(r, s, q)) return true;
  return false;
}

// Axis to drop so that the projection of a non-degenerate triangle stays non-degenerate: the axis of the
// largest |normal| component, computed exactly.
int drop_axis(const Vec3& a, const Vec3& b, const Vec3& c) {
  // Exact shortcut (flat cloth in a coordinate plane): a coordinate the three share makes u, v zero there, so
  // the normal's other two components are exactly 0 and that axis is the largest (the triangle is not
  // degenerate where this is called).
  for (int k = 0; k < 3; ++k)
    if (a[k] == b[k] && b[k] == c[k]) return k;
  mpq_class u[3], v[3];
  for (int k = 0; k < 3; ++k)
    u[k] = mpq_class(b[k]) - mpq_class(a[k]), v[k] = mpq_class(c[k]) - mpq_class(a[k]);
  const mpq_class n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  int best = 0;
  for (int k = 1; k < 3; ++k)
    if (abs(n[k]) > abs(n[best])) best = k;
  return best;
}

bool point_in_triangle_2d(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, int drop) {
  const int s1 = orient2d(a, b, p, drop), s2 = orient2d(b, c, p, drop), s3 = orient2d(c, a, p, drop);
  return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

bool degenerate(const Vec3& a, const Vec3& b, const Vec3& c) {
  for (int drop = 0; drop < 3; ++drop)
    if (orient2d(a, b, c, drop) != 0) return false;
  return true;
}

// Closed segment pq against closed non-degenerate triangle abc.
bool segment_meets_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  const int op = orient3d(a, b, c, p), oq = orient3d(a, b, c, q);
  if (op * oq > 0) return false;
  if (op == 0 && oq == 0) {  // in the triangle's plane: a 2D problem
    const int drop = drop_axis(a, b, c);
    return point_in_triangle_2d(p, a, b, c, drop) || segments_meet_2d(p, q, a, b, drop) ||
           segments_meet_2d(p, q, b, c, drop) || segments_meet_2d(p, q, c, a, drop);
  }
  // pq meets the plane in one point; it is in the closed triangle iff the line pq passes on the same side of
  // all three edges (or on one).
  const int s1 = orient3d(p, q, a, b), s2 = orient3d(p, q, b, c), s3 = orient3d(p, q, c, a);
  return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

// Closed segment pq against closed segment rs in 3D (for degenerate triangles).
bool segments_meet_3d(const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& s) {
  // Coplanar iff orient3d == 0; then pick a projection plane in which they are not both collapsed.
  if (orient3d(p, q, r, s) != 0) return false;
  for (int drop = 0; drop < 3; ++drop) {
    // A projection along `drop` is faithful if the plane (or line) of the four points is not parallel to it;
    // checking all three and requiring agreement where non-degenerate is exact but slower; use the first
    // projection in which some triple is not collinear, else (all collinear) any with distinct points.
    if (orient2d(p, q, r, drop) != 0 || orient2d(p, q, s, drop) != 0 || orient2d(r, s, p, drop) != 0)
      return segments_meet_2d(p, q, r, s, drop);
  }
  // All four points collinear in every projection: they are collinear in 3D; test overlap in every axis.
  for (int k = 0; k < 3; ++k)
    if (std::max(std::min(p[k], q[k]), std::min(r[k], s[k])) >
        std::min(std::max(p[k], q[k]), std::max(r[k], s[k])))
      return false;
  return true;
}

}  // namespace

int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const double adx = a.x() - d.x(), bdx = b.x() - d.x(), cdx = c.x() - d.x();
  const double ady = a.y() - d.y(), bdy = b.y() - d.y(), cdy = c.y() - d.y();
  const double adz = a.z() - d.z(), bdz = b.z() - d.z(), cdz = c.z() - d.z();
  const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
  const double cdxady = cdx * ady, adxcdy = adx * cdy;
  const double adxbdy = adx * bdy, bdxady = bdx * ady;
  // Shewchuk 1997, orient3d() with errboundA: det of [a-d; b-d; c-d] expanded along z.
  const double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
  const double permanent = (std::abs(bdxcdy) + std::abs(cdxbdy)) * std::abs(adz) +
                           (std::abs(cdxady) + std::abs(adxcdy)) * std::abs(bdz) +
                           (std::abs(adxbdy) + std::abs(bdxady)) * std::abs(cdz);
  const double bound = kO3dBound * permanent;
  if (det > bound) return 1;
  if (-det > bound) return -1;
  // Exact zeros without GMP: a zero column (the four points share a coordinate: flat cloth in a coordinate
  // plane) or a zero row (a point equal to d). Differences of doubles are 0 exactly when the two are equal.
  if ((adx == 0.0 && bdx == 0.0 && cdx == 0.0) || (ady == 0.0 && bdy == 0.0 && cdy == 0.0) ||
      (adz == 0.0 && bdz == 0.0 && cdz == 0.0))
    return 0;
  if (a == d || b == d || c == d) return 0;
  return orient3d_exact(a, b, c, d);
}

int orient2d(const Vec3& a, const Vec3& b, const Vec3& c, int drop) {
  const int i = drop == 0 ? 1 : 0, j = drop == 2 ? 1 : 2;
  const double l = (a[i] - c[i]) * (b[j] - c[j]), r = (a[j] - c[j]) * (b[i] - c[i]);
  const double det = l - r;
  // Shewchuk 1997, orient2d() with ccwerrboundA.
  const double bound = kO2dBound * (std::abs(l) + std::abs(r));
  if (det > bound) return 1;
  if (-det > bound) return -1;
  // Exact zeros without GMP: the three share a coordinate (points on a grid line), or a or b equals c.
  if ((a[i] == c[i] && b[i] == c[i]) || (a[j] == c[j] && b[j] == c[j])) return 0;
  if ((a[i] == c[i] && a[j] == c[j]) || (b[i] == c[i] && b[j] == c[j])) return 0;
  const mpq_class el = (mpq_class(a[i]) - mpq_class(c[i])) * (mpq_class(b[j]) - mpq_class(c[j]));
  const mpq_class er = (mpq_class(a[j]) - mpq_class(c[j])) * (mpq_class(b[i]) - mpq_class(c[i]));
  return sign(el - er);
}

bool triangles_intersect(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0, const Vec3& b1,
                         const Vec3& b2) {
  // Quick reject on exact bounding boxes (comparisons of doubles are exact).
  for (int k = 0; k < 3; ++k) {
    if (std::max({a0[k], a1[k], a2[k]}) < std::min({b0[k], b1[k], b2[k]})) return false;
    if (std::max({b0[k], b1[k], b2[k]}) < std::min({a0[k], a1[k], a2[k]})) return false;
  }
  const bool da = degenerate(a0, a1, a2), db = degenerate(b0, b1, b2);
  const Vec3* A[3] = {&a0, &a1, &a2};
  const Vec3* B[3] = {&b0, &b1, &b2};
  if (da && db) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (segments_meet_3d(*A[i], *A[(i + 1) % 3], *B[j], *B[(j + 1) % 3])) return true;
    return false;
  }
  // Two closed triangles meet iff an edge of one meets the other (non-coplanar: the intersection segment
  // ends on edges; coplanar: edges cross, or one contains the other and so its edges too). A degenerate
  // triangle is the union of its edges, so only its edges are tested against the other.
  if (!da)
    for (int j = 0; j < 3; ++j)
      if (segment_meets_triangle(*B[j], *B[(j + 1) % 3], a0, a1, a2)) return true;
  if (!db)
    for (int i = 0; i < 3; ++i)
      if (segment_meets_triangle(*A[i], *A[(i + 1) % 3], b0, b1, b2)) return true;
  return false;
}

}  // namespace loom::collision
