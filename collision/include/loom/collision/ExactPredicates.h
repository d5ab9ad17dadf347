#pragma once
// Exact geometric predicates on double coordinates: a floating-point filter with Shewchuk's a-priori error
// bound (Shewchuk 1997, "Adaptive Precision Floating-Point Arithmetic and Fast Robust Geometric Predicates",
// Sec. 4.2, errboundA), and an exact GMP rational evaluation when the filter cannot decide the sign.
// Assumes no overflow or underflow in the filter (|coordinates| well inside 1e-100..1e100).
#include "loom/cloth/Types.h"

namespace loom::collision {

using loom::cloth::Vec3;

// Sign of det[a - d; b - d; c - d]: +1, 0 or -1, exact.
int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);
// Sign of det[a - c; b - c] in the coordinate plane that drops axis `drop` (0, 1, 2).
int orient2d(const Vec3& a, const Vec3& b, const Vec3& c, int drop);

// Closed triangles (a0, a1, a2) and (b0, b1, b2) share at least one point (touching counts). Exact.
// Degenerate (zero-area) triangles are handled as the union of their edges.
bool triangles_intersect(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0, const Vec3& b1,
                         const Vec3& b2);

}  // namespace loom::collision
