#include "loom/collision/SweptCollider.h"

#include <algorithm>
#include <cmath>

#include "loom/collision/ColliderDistance.h"

namespace loom::collision {

Transform interpolate_pose(const Transform& a, const Transform& b, double t) {
  if (t <= 0.0) return a;
  if (t >= 1.0) return b;
  const Eigen::Quaterniond qa(a.linear()), qb(b.linear());
  Transform out = Transform::Identity();
  out.linear() = qa.slerp(t, qb).toRotationMatrix();
  out.translation() = (1.0 - t) * a.translation() + t * b.translation();
  return out;
}

double rotation_angle(const Transform& a, const Transform& b) {
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(a.linear().transpose() * b.linear()));
  return std::abs(aa.angle());
}

Vec3 surface_velocity(const Transform& a, const Transform& b, double h, const Vec3& x) {
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(b.linear() * a.linear().transpose()));
  const Vec3 omega = aa.axis() * (aa.angle() / h);  // rad/s, world
  return (b.translation() - a.translation()) / h + omega.cross(x - b.translation());
}

SweptHit swept_point(const Collider& c, const Vec3& p0, const Vec3& p1, double separation,
                     int max_iterations) {
  SweptHit out;
  const Vec3 c0 = c.prev.translation(), c1 = c.curr.translation();
  const double theta = rotation_angle(c.prev, c.curr);
  const double lip =
      (p1 - p0).norm() + (c1 - c0).norm() + theta * std::max((p0 - c0).norm(), (p1 - c1).norm());
  // A gap below 10% of the separation counts as a hit: it ends the slow (linear) convergence of an oblique
  // approach; the contact it reports is then within 1.1 x separation (a false positive, never a miss).
  const double slack = 0.1 * separation;
  double t = 0.0;
  for (int it = 0; it < max_iterations; ++it) {
    out.iterations = it + 1;
    const Transform pose = interpolate_pose(c.prev, c.curr, t);
    const Vec3 p = (1.0 - t) * p0 + t * p1;
    const Vec3 q = pose.inverse(Eigen::Isometry) * p;
    Vec3 n;
    const double gap = local_signed_distance(c.shape, c.geometry.get(), q, &n) - separation;
    if (gap <= slack) {
      out.hit = true, out.toi = t, out.local = q, out.normal = n;
      return out;
    }
    if (!(lip > 0.0) || gap >= lip * (1.0 - t)) return out;  // cannot close the gap in the time left
    t += gap / lip;
    if (t >= 1.0) return out;
  }
  // Budget exhausted (a grazing approach): conservatively a hit at the current t.
  const Transform pose = interpolate_pose(c.prev, c.curr, t);
  out.hit = true, out.toi = t;
  out.local = pose.inverse(Eigen::Isometry) * ((1.0 - t) * p0 + t * p1);
  local_signed_distance(c.shape, c.geometry.get(), out.local, &out.normal);
  return out;
}

SweptSegmentHit swept_segment_capsule(const Collider& c, const Vec3& a0, const Vec3& b0, const Vec3& a1,
                                      const Vec3& b1, double separation, int max_iterations) {
  SweptSegmentHit out;
  const Vec3 c0 = c.prev.translation(), c1 = c.curr.translation();
  const double theta = rotation_angle(c.prev, c.curr);
  // Segment-to-segment distance is 1-Lipschitz in the largest endpoint displacement of either segment.
  const double lip =
      std::max((a1 - a0).norm(), (b1 - b0).norm()) + (c1 - c0).norm() + theta * c.shape.half_height;
  const double slack = 0.1 * separation;
  double t = 0.0;
  auto eval = [&](double tt, bool record) {
    const Transform pose = interpolate_pose(c.prev, c.curr, tt);
    double s = 0.0;
    Vec3 n;
    const Vec3 a = (1.0 - tt) * a0 + tt * a1, b = (1.0 - tt) * b0 + tt * b1;
    const double d = segment_capsule_distance(c, pose, a, b, &s, &n);
    if (record) {
      out.toi = tt, out.s = s;
      out.normal_local = pose.linear().transpose() * n;
      const Vec3 on_edge = a + s * (b - a);
      out.axis_local = pose.inverse(Eigen::Isometry) * (on_edge - (d + c.shape.radius) * n);
    }
    return d;
  };
  for (int it = 0; it < max_iterations; ++it) {
    const double gap = eval(t, false) - separation;
    if (gap <= slack) {
      out.hit = true;
      eval(t, true);
      return out;
    }
    if (!(lip > 0.0) || gap >= lip * (1.0 - t)) return out;
    t += gap / lip;
    if (t >= 1.0) return out;
  }
  out.hit = true;
  eval(t, true);
  return out;
}

}  // namespace loom::collision
