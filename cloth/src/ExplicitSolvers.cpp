#include "loom/cloth/ExplicitSolvers.h"

#include <algorithm>

#include "loom/cloth/Error.h"

namespace loom::cloth {

// docs/references.md, "Time integration" for each scheme. Kinematic vertices (inverse mass 0) move by x += h
// v.

void ExplicitEuler::step(Cloth& cloth, double t, double h, int threads) {
  ClothState& s = cloth.state();
  cloth.compute_forces(s.x, s.v, t, threads, f_);
  const int n = s.size();
  s.x_prev.resize(n);
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
  for (int i = 0; i < n; ++i) {
    s.x_prev[i] = s.x[i];
    s.x[i] += h * s.v[i];
    s.v[i] += h * s.inv_mass[i] * f_[i];
  }
}

void SymplecticEuler::step(Cloth& cloth, double t, double h, int threads) {
  ClothState& s = cloth.state();
  cloth.compute_forces(s.x, s.v, t, threads, f_);
  const int n = s.size();
  s.x_prev.resize(n);
  // x_prev is saved in the parallel update (a separate serial copy capped the 2-thread speed-up).
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
  for (int i = 0; i < n; ++i) {
    s.x_prev[i] = s.x[i];
    s.v[i] += h * s.inv_mass[i] * f_[i];
    s.x[i] += h * s.v[i];
  }
}

void Verlet::step(Cloth& cloth, double t, double h, int threads) {
  ClothState& s = cloth.state();
  const int n = s.size();
  cloth.compute_forces(s.x, s.v, t, threads, f_);
  // History is the state's x_prev, so corrections made by later stages (constraints, collisions) carry
  // into the next step as Verlet expects.
  if (h_prev_ <= 0.0 || static_cast<int>(s.x_prev.size()) != n) {
    // Start from (x, v): x_{-1} = x - h v + h²/2 a makes the first step x + h v + h²/2 a (exact for constant
    // a).
    s.x_prev.resize(n);
    for (int i = 0; i < n; ++i) s.x_prev[i] = s.x[i] - h * s.v[i] + 0.5 * h * h * s.inv_mass[i] * f_[i];
  } else if (h != h_prev_) {
    // The step changed: rescale the stored displacement so the implied velocity is kept.
    for (int i = 0; i < n; ++i) s.x_prev[i] = s.x[i] - (s.x[i] - s.x_prev[i]) * (h / h_prev_);
  }
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
  for (int i = 0; i < n; ++i) {
    const Vec3 x = s.x[i];
    if (s.inv_mass[i] == 0.0) {
      s.x[i] = x + h * s.v[i];
    } else {
      const Vec3 a = s.inv_mass[i] * f_[i];
      s.x[i] = 2.0 * x - s.x_prev[i] + h * h * a;
      // Velocity at the new position, second order: v(t+h) = (x+ - x)/h + h/2 a.
      s.v[i] = (s.x[i] - x) / h + 0.5 * h * a;
    }
    s.x_prev[i] = x;
  }
  h_prev_ = h;
}

}  // namespace loom::cloth
