#include "loom/cloth/AeroTerm.h"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>

#include "Numbers.h"
#include "TriangleGather.h"
#include "loom/cloth/Error.h"

namespace loom::cloth {

Vec3 WindSettings::velocity_at(double t) const {
  double scale = 1.0;
  for (const Gust& g : gusts) scale += g.amplitude * std::sin(kTwoPi * g.frequency * t + g.phase);
  Vec3 w = velocity * scale;
  if (swing_angle != 0.0) {
    const double angle = swing_angle * std::sin(kTwoPi * swing_frequency * t);
    w = Eigen::AngleAxisd(angle, swing_axis) * w;
  }
  return w;
}

double WindSettings::max_speed() const {
  double scale = 1.0;
  for (const Gust& g : gusts) scale += std::abs(g.amplitude);
  return velocity.norm() * scale;
}

void WindSettings::validate(const std::string& file, const std::string& where) {
  auto show = [](double v) {
    char s[32];
    std::snprintf(s, sizeof s, "%.9g", v);
    return std::string(s);
  };
  auto check = [&](const std::string& field, double value, double lo, double hi) {
    if (!std::isfinite(value)) throw Error(file, where + "." + field, "must be a finite number");
    if (!(value >= lo && value <= hi))
      throw Error(file, where + "." + field,
                  "must be in [" + show(lo) + ", " + show(hi) + "] (got " + show(value) + ")");
  };
  if (!velocity.allFinite()) throw Error(file, where + ".velocity", "must be finite");
  if (velocity.norm() > 1000.0)
    throw Error(file, where + ".velocity", "must be at most 1000 m/s in magnitude");
  check("density", density, 0.0, 2000.0);
  check("drag", drag, 0.0, 10.0);
  check("lift", lift, 0.0, 10.0);
  for (size_t k = 0; k < gusts.size(); ++k) {
    const std::string g = "gusts[" + std::to_string(k) + "].";
    check(g + "amplitude", gusts[k].amplitude, 0.0, 1.0);
    check(g + "frequency", gusts[k].frequency, 0.0, 1000.0);
    check(g + "phase", gusts[k].phase, -1e6, 1e6);
  }
  check("swing.angle", swing_angle, 0.0, kPi);
  check("swing.frequency", swing_frequency, 0.0, 1000.0);
  // Scaled by its largest component first: an axis whose length overflows (1e300) or underflows (1e-300)
  // still has its direction.
  const double largest = swing_axis.cwiseAbs().maxCoeff();
  if (!swing_axis.allFinite() || !(largest > 0.0))
    throw Error(file, where + ".swing.axis", "must be a finite, non-zero vector");
  swing_axis /= largest;
  swing_axis.normalize();
}

AeroTerm::AeroTerm(const WindSettings& s, std::vector<Tri> triangles, int num_vertices)
    : s_(s), triangles_(std::move(triangles)) {
  vertex_triangles_.resize(num_vertices);
  for (size_t t = 0; t < triangles_.size(); ++t)
    for (int v : triangles_[t]) vertex_triangles_[v].push_back(static_cast<int>(t));
  tri_force_.resize(triangles_.size());
}

Vec3 AeroTerm::triangle_force(const WindSettings& s, const Vec3& x0, const Vec3& x1, const Vec3& x2,
                              const Vec3& v_mean, const Vec3& w) {
  const Vec3 N = (x1 - x0).cross(x2 - x0);  // |N| = 2A
  const double len = N.norm();
  const Vec3 u = w - v_mean;
  const double speed = u.norm();
  if (len == 0.0 || speed == 0.0) return Vec3::Zero();
  const Vec3 n = N / len, uh = u / speed;
  const double c = n.dot(uh);
  // ½ ρ A |u|² with A = |N| / 2.
  const double q = 0.25 * s.density * len * speed * speed;
  // Keckeisen et al. 2004 (AeroTerm.h): f_D = q C_D |c| û, f_L = q C_L c (n̂ - c û).
  return q * (s.drag * std::abs(c) * uh + s.lift * c * (n - c * uh));
}

void AeroTerm::add_forces(const EvalContext& c, Vec3s& f) const {
  const Vec3 w = s_.velocity_at(c.t);
  const int nt = static_cast<int>(triangles_.size());
  const int nv = static_cast<int>(vertex_triangles_.size());
#pragma omp parallel num_threads(c.threads) if (c.threads > 1 && nv >= kParallelMinVertices)
  {
#pragma omp for schedule(static)
    for (int t = 0; t < nt; ++t) {
      const Tri& tri = triangles_[t];
      const Vec3 v_mean = (c.v[tri[0]] + c.v[tri[1]] + c.v[tri[2]]) / 3.0;
      tri_force_[t] = triangle_force(s_, c.x[tri[0]], c.x[tri[1]], c.x[tri[2]], v_mean, w) / 3.0;
    }
    gather_triangle_forces(tri_force_, vertex_triangles_, f);
  }
}

}  // namespace loom::cloth
