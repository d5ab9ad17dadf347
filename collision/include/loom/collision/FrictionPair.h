#pragma once
// Coulomb coefficients of one material pair: a cloth against another cloth (self-collision stage) or
// against a collider (body-collision stage); they win over the defaults (the cloth materials' / the
// collider's coefficients). Within one cloth (self-contact): other_cloth == cloth. Scene key
// `collision.friction_pairs`.

namespace loom::collision {

struct FrictionPair {
  int cloth = 0;                 // index in the simulation's cloths
  int other_cloth = -1;          // index of the other cloth, or -1
  int collider = -1;             // index in the collider set, or -1
  double friction = 0.3;         // 1, kinetic coefficient
  double static_friction = 0.3;  // 1, static coefficient (>= friction)
};

}  // namespace loom::collision
