// Point-triangle and segment-segment distances (loom/collision/Distance.h): known values, degenerate input,
// double vs exact rational, and the exact minimum against sampled points.
#include <gtest/gtest.h>

#include <random>

#include "loom/collision/Distance.h"

namespace lc = loom::collision;
using lc::Vec3;

namespace {

mpq_class exact_d2(const Vec3& x, const Vec3& y) {
  mpq_class s = 0;
  for (int k = 0; k < 3; ++k) {
    const mpq_class d = mpq_class(x[k]) - mpq_class(y[k]);
    s += d * d;
  }
  return s;
}

// Exact squared distance from p to the point sum_i w_i v_i (weights as given, exactly).
mpq_class exact_d2_weighted(const Vec3& p, const Vec3* v, const double* w, int n) {
  mpq_class s = 0;
  for (int k = 0; k < 3; ++k) {
    mpq_class x = 0;
    for (int i = 0; i < n; ++i) x += mpq_class(w[i]) * mpq_class(v[i][k]);
    const mpq_class d = mpq_class(p[k]) - x;
    s += d * d;
  }
  return s;
}

Vec3 random_point(std::mt19937_64& rng, int mode) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> g(-2, 2);
  if (mode == 0) return Vec3(u(rng), u(rng), u(rng));
  return Vec3(g(rng), g(rng), g(rng)) * 0.5;  // lattice points: coincident, collinear, parallel cases
}

}  // namespace

TEST(Distance, KnownValues) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  auto r = lc::point_triangle_closest(Vec3(0.25, 0.25, 2), a, b, c);
  EXPECT_DOUBLE_EQ(r.distance_squared, 4.0);
  EXPECT_NEAR(r.weights[0], 0.5, 1e-15);
  EXPECT_NEAR(r.weights[1], 0.25, 1e-15);
  EXPECT_NEAR(r.weights[2], 0.25, 1e-15);
  EXPECT_DOUBLE_EQ(lc::point_triangle_closest(Vec3(2, 0, 0), a, b, c).distance_squared, 1.0);  // vertex b
  EXPECT_DOUBLE_EQ(lc::point_triangle_closest(Vec3(1, 1, 1), a, b, c).distance_squared, 1.5);  // edge bc
  EXPECT_EQ(lc::point_triangle_distance_squared_exact(Vec3(1, 1, 1), a, b, c), mpq_class(3, 2));
  // Crossing segments 0.5 apart; parallel overlapping segments 2 apart; a zero-length segment.
  auto s = lc::segment_segment_closest(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0.5, -1, 0.5), Vec3(0.5, 1, 0.5));
  EXPECT_DOUBLE_EQ(s.distance_squared, 0.25);
  EXPECT_DOUBLE_EQ(s.s, 0.75);
  EXPECT_DOUBLE_EQ(s.t, 0.5);
  EXPECT_EQ(
      lc::segment_segment_distance_squared_exact(Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(1, 2, 0), Vec3(3, 2, 0)),
      4);
  EXPECT_EQ(
      lc::segment_segment_distance_squared_exact(Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(1, 1, 0), Vec3(1, -1, 0)),
      1);
}

TEST(Distance, DoubleAgreesWithExactAndExactIsTheMinimum) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int it = 0; it < 4000; ++it) {
    const int mode = it % 2;
    const Vec3 p = random_point(rng, mode), a = random_point(rng, mode), b = random_point(rng, mode),
               c = random_point(rng, mode), d = random_point(rng, mode);
    // Point-triangle.
    const auto r = lc::point_triangle_closest(p, a, b, c);
    const mpq_class e = lc::point_triangle_distance_squared_exact(p, a, b, c);
    EXPECT_NEAR(r.distance_squared, e.get_d(), 1e-12) << it;
    EXPECT_NEAR(r.weights.sum(), 1.0, 1e-12);
    EXPECT_GE(r.weights.minCoeff(), -1e-12);
    const Vec3 tri[3] = {a, b, c};
    const double w[3] = {r.weights[0], r.weights[1], r.weights[2]};
    const mpq_class at = exact_d2_weighted(p, tri, w, 3);  // the returned point is (nearly) a minimiser
    EXPECT_LE(mpq_class(at - e).get_d(), 1e-12) << it;
    for (int k = 0; k < 8; ++k) {  // no point of the triangle is closer than the exact minimum
      double s = unit(rng), t = unit(rng);
      if (s + t > 1) s = 1 - s, t = 1 - t;
      const double ws[3] = {1 - s - t, s, t};
      EXPECT_GE(exact_d2_weighted(p, tri, ws, 3) - e + mpq_class(1e-15), 0) << it;
    }
    // Segment-segment.
    const auto ss = lc::segment_segment_closest(p, a, c, d);
    const mpq_class es = lc::segment_segment_distance_squared_exact(p, a, c, d);
    EXPECT_NEAR(ss.distance_squared, es.get_d(), 1e-12) << it;
    const Vec3 x = p + ss.s * (a - p), y = c + ss.t * (d - c);
    EXPECT_LE(mpq_class(exact_d2(x, y) - es).get_d(), 1e-12) << it;
    for (int k = 0; k < 8; ++k) {
      const double s = unit(rng), t = unit(rng);
      EXPECT_GE(mpq_class(exact_d2(p + s * (a - p), c + t * (d - c)) - es).get_d(), -1e-15) << it;
    }
  }
}
