#pragma once
// Coulomb coefficients of one material pair: a cloth against another cloth (self-collision stage) or
// against a collider (body-collision stage); they win over the defaults (the cloth materials' / the
// collider's coefficients). Within one cloth (self-contact): other_cloth == cloth. Scene key
// `collision.friction_pairs`. Also the Coulomb law the body-contact stages apply with those coefficients.
#include "loom/collision/Collider.h"

namespace loom::collision {

// Coulomb friction (Bridson et al. 2002, Sec. 7.2) on a relative velocity, or on a displacement over the step
// in its place: `rel` is the vertex's motion relative to the surface, n the outward unit normal. Returns the
// tangential part after friction: dropped when within mu_s of the inward part (which stands for the normal
// impulse; static), else shortened by mu_k of it (kinetic).
Vec3 coulomb_tangent(const Vec3& rel, const Vec3& n, double mu_s, double mu_k);

struct FrictionPair {
  int cloth = 0;                 // index in the simulation's cloths
  int other_cloth = -1;          // index of the other cloth, or -1
  int collider = -1;             // index in the collider set, or -1
  double friction = 0.3;         // 1, kinetic coefficient
  double static_friction = 0.3;  // 1, static coefficient (>= friction)
};

}  // namespace loom::collision
