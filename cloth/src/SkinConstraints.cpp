#include "loom/cloth/SkinConstraints.h"

#include <cmath>
#include <limits>

#include "loom/cloth/Error.h"

namespace loom::cloth {

namespace {

void check_map(const std::vector<double>& map, int n, const std::string& name, bool allow_inf,
               const std::string& source) {
  if (map.empty()) return;
  if (static_cast<int>(map.size()) != n)
    throw Error(source, name,
                "has " + std::to_string(map.size()) + " values for " + std::to_string(n) + " vertices");
  for (size_t i = 0; i < map.size(); ++i) {
    const double d = map[i];
    const bool ok = allow_inf ? d >= 0.0 : std::isfinite(d);
    if (!ok)
      throw Error(source, name + "[" + std::to_string(i) + "]",
                  std::to_string(d) + (allow_inf ? " must be >= 0" : " must be finite"));
  }
}

// Any unit vector perpendicular to n.
Vec3 perpendicular(const Vec3& n) {
  const Vec3 a = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return n.cross(a).normalized();
}

}  // namespace

void SkinConstraintSettings::validate(int num_vertices, const std::string& source) const {
  check_map(max_distance, num_vertices, "max_distance", true, source);
  check_map(backstop_distance, num_vertices, "backstop_distance", false, source);
  if (!(backstop_radius >= 0.0) || !std::isfinite(backstop_radius))
    throw Error(source, "backstop_radius", std::to_string(backstop_radius) + " must be finite and >= 0");
  if (!(drive_stiffness >= 0.0) || !std::isfinite(drive_stiffness))
    throw Error(source, "drive_stiffness", std::to_string(drive_stiffness) + " must be finite and >= 0");
  if (!(max_distance_multiplier >= 0.0))
    throw Error(source, "max_distance_multiplier", std::to_string(max_distance_multiplier) + " must be >= 0");
}

double SkinConstraintSettings::effective_max_distance(int i) const {
  if (max_distance.empty()) return std::numeric_limits<double>::infinity();
  const double d = max_distance[i];
  // 0 · ∞ (a free vertex with the multiplier at 0) is fully skinned; ∞ · 0 (multiplier ∞, pinned vertex) too.
  if (d == 0.0 || max_distance_multiplier == 0.0) return 0.0;
  return max_distance_multiplier * d;
}

SkinConstraints::SkinConstraints(SkinConstraintSettings settings, int num_vertices, const std::string& source)
    : s_(std::move(settings)), n_(num_vertices) {
  s_.validate(num_vertices, source);
}

void SkinConstraints::set_max_distance_multiplier(double s, const std::string& source) {
  if (!(s >= 0.0)) throw Error(source, "max_distance_multiplier", std::to_string(s) + " must be >= 0");
  s_.max_distance_multiplier = s;
}

double SkinConstraints::backstop_depth(int i, const Vec3& x, const Vec3& p, const Vec3& n) const {
  if (s_.backstop_distance.empty()) return 0.0;
  const double b = s_.backstop_distance[i];
  if (s_.backstop_radius == 0.0) return std::max(0.0, -b - (x - p).dot(n));
  const Vec3 c = p - (b + s_.backstop_radius) * n;
  return std::max(0.0, s_.backstop_radius - (x - c).norm());
}

long SkinConstraints::apply(const Vec3s& p, const Vec3s& n, double h, Vec3s& x, Vec3s& v) const {
  const double drive = s_.drive_stiffness > 0.0 ? 1.0 - std::exp(-s_.drive_stiffness * h) : 0.0;
  const bool backstop = !s_.backstop_distance.empty();
  const double R = s_.backstop_radius;
  long moved = 0;
  for (int i = 0; i < n_; ++i) {
    const Vec3 x0 = x[i];
    Vec3 y = x0;
    if (drive > 0.0) y += drive * (p[i] - y);
    const double d = s_.effective_max_distance(i);
    if (d == 0.0) {
      y = p[i];
    } else if (std::isfinite(d)) {
      const Vec3 r = y - p[i];
      const double len = r.norm();
      if (len > d) y = p[i] + (d / len) * r;
    }
    if (backstop && d > 0.0) {
      const double b = s_.backstop_distance[i];
      if (R == 0.0) {
        // Half-space projection: only the normal component changes, so |y - p| does not grow when b >= 0.
        const double behind = -b - (y - p[i]).dot(n[i]);
        if (behind > 0.0) y += behind * n[i];
      } else {
        const Vec3 c = p[i] - (b + R) * n[i];
        const Vec3 r = y - c;
        const double len = r.norm();
        if (len < R) {
          const Vec3 dir = len > 0.0 ? Vec3(r / len) : Vec3(n[i]);
          Vec3 z = c + R * dir;
          if ((z - p[i]).norm() > d) {
            // The closest point on the circle where the backstop sphere meets the max-distance sphere, in the
            // plane of the axis and y. Along the axis from c: a = (R² - d² + D²) / (2D), radius sqrt(R² -
            // a²).
            const double D = b + R;
            const double a = (R * R - d * d + D * D) / (2.0 * D);
            const double rho2 = R * R - a * a;
            if (rho2 >= 0.0) {
              Vec3 e = r - r.dot(n[i]) * n[i];
              e = e.norm() > 0.0 ? Vec3(e.normalized()) : perpendicular(n[i]);
              z = c + a * n[i] + std::sqrt(rho2) * e;
            }
          }
          y = z;
        }
      }
    }
    if (y != x0) {
      x[i] = y;
      v[i] += (y - x0) / h;
      ++moved;
    }
  }
  return moved;
}

}  // namespace loom::cloth
