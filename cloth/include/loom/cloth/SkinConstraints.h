#pragma once
// Skin constraints: a constraint pass that ties each simulated vertex to its skinned position (the garment
// mesh deformed by the skeleton, computed by the caller and passed as plain arrays). Applied after the
// solver, at the end of each step [t, t + h], against the skinned targets p_i and unit normals n_i at t + h:
//   1. animation drive: x_i += (1 - exp(-k h)) (p_i - x_i), k the drive stiffness (1/s); 0 = off.
//   2. max distance:    |x_i - p_i| <= s d_i, d_i the vertex's max distance (m), s the global multiplier;
//                       s d_i = 0 puts the vertex exactly on p_i (fully skinned), d_i = ∞ leaves it free.
//   3. backstop:        with radius R = 0, the half-space (x_i - p_i)·n_i >= -b_i (a plane b_i behind the
//                       skinned position along its normal); with R > 0, outside the sphere of radius R
//                       centred at p_i - (b_i + R) n_i. A vertex behind it is moved to the closest allowed
//                       point; with a sphere that point also keeps the max distance when the two sets meet.
// Each correction Δx also changes the velocity by Δx / h, so the next step does not undo it (position-based
// dynamics). The order (drive, max distance, backstop) makes the backstop hold at the end of every step.
// Jolt's skinned constraints (max distance, backstop distance and radius) and Unreal Chaos Cloth's
// MaxDistance/Backstop/AnimDrive are this pass.
#include <string>
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::cloth {

struct SkinConstraintSettings {
  std::vector<double> max_distance;       // m per vertex, >= 0 (∞ allowed: free); empty = no max distance
  std::vector<double> backstop_distance;  // m per vertex, finite; empty = no backstop
  double backstop_radius = 0.0;           // m, >= 0; 0 = plane along the skinned normal, > 0 = sphere
  double drive_stiffness = 0.0;           // 1/s, >= 0; 0 = no animation drive
  double max_distance_multiplier = 1.0;   // 1, >= 0: 0 = fully skinned, 1 = the map, ∞ = fully simulated

  // Throws loom::Error(source, field, problem) naming the field ("max_distance[3]", "backstop_radius", ...)
  // for a negative or NaN value or a map whose size is not `num_vertices`.
  void validate(int num_vertices, const std::string& source = "") const;
  // s d_i: the vertex's max distance after the multiplier (∞ without a max-distance map).
  double effective_max_distance(int i) const;
};

class SkinConstraints {
 public:
  // Validates `settings` for a cloth of `num_vertices` vertices (SkinConstraintSettings::validate).
  SkinConstraints(SkinConstraintSettings settings, int num_vertices, const std::string& source = "");
  const SkinConstraintSettings& settings() const { return s_; }
  // Sets the global multiplier (>= 0). Throws loom::Error(source, "max_distance_multiplier", ...).
  void set_max_distance_multiplier(double s, const std::string& source = "");

  // Applies the pass to positions x and velocities v (num_vertices each) for targets p and unit normals n at
  // the end of a step of length h (s). Returns the number of vertices moved.
  long apply(const Vec3s& p, const Vec3s& n, double h, Vec3s& x, Vec3s& v) const;

  // Distance (m) by which x is behind the backstop (0 when it is not): the test of contract 3.
  double backstop_depth(int i, const Vec3& x, const Vec3& p, const Vec3& n) const;

 private:
  SkinConstraintSettings s_;
  int n_ = 0;
};

}  // namespace loom::cloth
