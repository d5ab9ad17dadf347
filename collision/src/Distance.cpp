// Point-triangle and segment-segment distances, one template for double and exact rationals (Distance.h).
#include "loom/collision/Distance.h"

#include <algorithm>
#include <array>

namespace loom::collision {
namespace {

template <class T>
struct V3 {
  T x, y, z;
};
template <class T>
V3<T> sub(const V3<T>& a, const V3<T>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
T dot(const V3<T>& a, const V3<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
V3<T> cross(const V3<T>& a, const V3<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T>
V3<T> lift(const Vec3& v) {
  return {T(v.x()), T(v.y()), T(v.z())};  // exact for mpq_class and double
}

// Point p to segment a + s (b - a), s in [0, 1]: returns d^2 and s (Ericson 2005, Sec. 5.1.2).
template <class T>
T point_segment(const V3<T>& p, const V3<T>& a, const V3<T>& b, T& s) {
  const V3<T> ab = sub(b, a), ap = sub(p, a);
  const T len2 = dot(ab, ab);
  const T num = dot(ap, ab);
  if (len2 == 0 || num <= 0) {
    s = 0;
  } else if (num >= len2) {
    s = 1;
  } else {
    s = num / len2;
  }
  const V3<T> d = {ap.x - s * ab.x, ap.y - s * ab.y, ap.z - s * ab.z};
  return dot(d, d);
}

// Returns d^2 and the barycentric weights w of the closest point.
template <class T>
T point_triangle(const V3<T>& p, const V3<T>& a, const V3<T>& b, const V3<T>& c, std::array<T, 3>& w) {
  const V3<T> n = cross(sub(b, a), sub(c, a));
  const T n2 = dot(n, n);
  if (n2 > 0) {
    // Signed sub-areas of the projection of p (Ericson 2005, Sec. 3.4): inside iff all are >= 0.
    const T wa = dot(n, cross(sub(c, b), sub(p, b)));
    const T wb = dot(n, cross(sub(a, c), sub(p, c)));
    const T wc = dot(n, cross(sub(b, a), sub(p, a)));
    if (wa >= 0 && wb >= 0 && wc >= 0) {
      const T h = dot(n, sub(p, a));
      w = {wa / n2, wb / n2, wc / n2};
      return h * h / n2;
    }
  }
  // Outside (or a degenerate triangle): the closest point is on an edge.
  T s0, s1, s2;
  const T d0 = point_segment(p, a, b, s0), d1 = point_segment(p, b, c, s1), d2 = point_segment(p, c, a, s2);
  if (d0 <= d1 && d0 <= d2) {
    w = {T(1) - s0, s0, T(0)};
    return d0;
  }
  if (d1 <= d2) {
    w = {T(0), T(1) - s1, s1};
    return d1;
  }
  w = {s2, T(0), T(1) - s2};
  return d2;
}

// Returns d^2 and the parameters (s, t) of the closest points (Ericson 2005, Sec. 5.1.9, with the boundary
// reduced to the four endpoint-to-segment distances).
template <class T>
T segment_segment(const V3<T>& p0, const V3<T>& p1, const V3<T>& q0, const V3<T>& q1, T& s, T& t) {
  const V3<T> d1 = sub(p1, p0), d2 = sub(q1, q0), r = sub(p0, q0);
  const T a = dot(d1, d1), e = dot(d2, d2), b = dot(d1, d2), c = dot(d1, r), f = dot(d2, r);
  const T den = a * e - b * b;  // >= 0 (Cauchy-Schwarz); 0 iff parallel or degenerate
  if (den > 0) {
    const T sn = b * f - c * e, tn = a * f - b * c;
    if (sn > 0 && sn < den && tn > 0 && tn < den) {
      s = sn / den;
      t = tn / den;
      const V3<T> d = {r.x + s * d1.x - t * d2.x, r.y + s * d1.y - t * d2.y, r.z + s * d1.z - t * d2.z};
      return dot(d, d);
    }
  }
  T u;
  T best = point_segment(p0, q0, q1, u);
  s = 0, t = u;
  T dd = point_segment(p1, q0, q1, u);
  if (dd < best) best = dd, s = 1, t = u;
  dd = point_segment(q0, p0, p1, u);
  if (dd < best) best = dd, s = u, t = 0;
  dd = point_segment(q1, p0, p1, u);
  if (dd < best) best = dd, s = u, t = 1;
  return best;
}

}  // namespace

double point_segment_distance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 d = b - a;
  const double l2 = d.squaredNorm();
  const double s = l2 > 0.0 ? std::clamp((p - a).dot(d) / l2, 0.0, 1.0) : 0.0;
  return (p - (a + s * d)).norm();
}

PointTriangleClosest point_triangle_closest(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  std::array<double, 3> w;
  PointTriangleClosest r;
  r.distance_squared = point_triangle(lift<double>(p), lift<double>(a), lift<double>(b), lift<double>(c), w);
  r.weights = Vec3(w[0], w[1], w[2]);
  return r;
}

SegmentSegmentClosest segment_segment_closest(const Vec3& p0, const Vec3& p1, const Vec3& q0,
                                              const Vec3& q1) {
  SegmentSegmentClosest r;
  r.distance_squared =
      segment_segment(lift<double>(p0), lift<double>(p1), lift<double>(q0), lift<double>(q1), r.s, r.t);
  return r;
}

mpq_class point_triangle_distance_squared_exact(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  std::array<mpq_class, 3> w;
  return point_triangle(lift<mpq_class>(p), lift<mpq_class>(a), lift<mpq_class>(b), lift<mpq_class>(c), w);
}

mpq_class segment_segment_distance_squared_exact(const Vec3& p0, const Vec3& p1, const Vec3& q0,
                                                 const Vec3& q1) {
  mpq_class s, t;
  return segment_segment(lift<mpq_class>(p0), lift<mpq_class>(p1), lift<mpq_class>(q0), lift<mpq_class>(q1),
                         s, t);
}

}  // namespace loom::collision
