#pragma once
// Swept tests against a moving collider. Within a step a collider moves from `prev` to `curr` by
// the screw-free interpolation T(t) = (slerp(R0, R1, t), lerp(c0, c1, t)), t in [0, 1]; a cloth vertex moves
// linearly from p0 to p1. The earliest t at which the point comes within `separation` of the surface is found
// by conservative advancement (Mirtich 1996, "Impulse-based dynamic simulation of rigid body systems",
// Ch. 3; Zhang, Redon, Lee, Kim 2006, "Continuous collision detection for articulated models using Taylor
// models and temporal culling"): the signed distance d(t) is L-Lipschitz in t with
//   L = |p1 - p0| + |c1 - c0| + theta * max(|p0 - c0|, |p1 - c1|),
// (theta = rotation angle from R0 to R1; the point's velocity in the body frame is R^T (p' - c') - w x q and
// |p(t) - c(t)| is convex in t), so stepping t by (d - separation) / L never passes a root. No false
// negatives; when the iteration budget runs out a hit is reported at the current t (a false positive).
#include "loom/collision/Collider.h"

namespace loom::collision {

// Pose at fraction t in [0, 1] between a and b (translation lerp, rotation slerp).
Transform interpolate_pose(const Transform& a, const Transform& b, double t);
// Rotation angle (rad) from a's orientation to b's.
double rotation_angle(const Transform& a, const Transform& b);
// Velocity (m/s) of the body point that is at world x at the end of a step of h seconds from a to b.
Vec3 surface_velocity(const Transform& a, const Transform& b, double h, const Vec3& x);

struct SweptHit {
  bool hit = false;
  double toi = 1.0;            // 1, fraction of the step (lower bound on the first contact)
  Vec3 local = Vec3::Zero();   // m, the point at toi in the collider's frame
  Vec3 normal = Vec3::Zero();  // 1, outward normal at toi in the collider's frame
  int iterations = 0;
};

// Point moving p0 -> p1 against collider c moving c.prev -> c.curr: first t where the signed distance
// <= separation (m). max_iterations bounds the advancement (exhausted: hit at the current t).
SweptHit swept_point(const Collider& c, const Vec3& p0, const Vec3& p1, double separation,
                     int max_iterations = 64);

// Segment (a0 -> a1, b0 -> b1) against a capsule's axis (c.prev -> c.curr): first t where the segment comes
// within radius + separation of the axis. toi and normal as above (normal in world at toi: from the axis to
// the segment's closest point); `local` is unused.
struct SweptSegmentHit {
  bool hit = false;
  double toi = 1.0;                  // 1
  double s = 0.0;                    // 1, closest parameter on the segment at toi
  Vec3 normal_local = Vec3::Zero();  // 1, direction from the axis to the segment at toi, capsule frame
  Vec3 axis_local = Vec3::Zero();    // m, closest axis point at toi, capsule frame
};
SweptSegmentHit swept_segment_capsule(const Collider& c, const Vec3& a0, const Vec3& b0, const Vec3& a1,
                                      const Vec3& b1, double separation, int max_iterations = 64);

}  // namespace loom::collision
