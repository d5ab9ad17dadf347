// Camera framing and ground height: GL-free, shared by the offscreen Renderer and the viewer.
#include <algorithm>
#include <cmath>

#include "gl/Draw.h"
#include "loom/render/Renderer.h"

namespace loom::render {

using cloth::Vec3;
using gl::kPi;

Camera auto_camera(const Bounds& b, double aspect, double fov_deg) {
  Camera c;
  c.fov_deg = fov_deg;
  const Vec3 center = 0.5 * (b.lo + b.hi);
  const Vec3 f = -Vec3(0.55, 0.40, 1.0).normalized();  // viewing direction: from the front-right, above
  const Vec3 s = f.cross(Vec3(0, 1, 0)).normalized(), u = s.cross(f);
  const double tan_y = std::tan(0.5 * fov_deg * kPi / 180.0), tan_x = tan_y * aspect;
  // The smallest distance at which all eight box corners project inside the image (5% margin each side).
  double distance = 1e-3;
  for (int i = 0; i < 8; ++i) {
    const Vec3 p =
        Vec3(i & 1 ? b.hi.x() : b.lo.x(), i & 2 ? b.hi.y() : b.lo.y(), i & 4 ? b.hi.z() : b.lo.z()) - center;
    const double depth = p.dot(f);  // along the view direction
    distance = std::max(distance, depth + std::abs(p.dot(s)) / (0.9 * tan_x));
    distance = std::max(distance, depth + std::abs(p.dot(u)) / (0.9 * tan_y));
  }
  c.target = center;
  c.eye = center - distance * f;
  return c;
}

double ground_height(const Bounds& b) { return b.lo.y() > 0.0 ? 0.0 : b.lo.y() - 0.002; }

}  // namespace loom::render
