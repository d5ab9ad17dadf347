#pragma once
// Small helpers shared by the cloth tests.
#include <Eigen/Dense>
#include <memory>
#include <random>

#include "SymplecticSetup.h"
#include "loom/cloth/BlockMatrix.h"
#include "loom/cloth/Cloth.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Simulation.h"
#include "loom/cloth/Term.h"

namespace loom::test {

using cloth::Vec3;
using cloth::Vec3s;

// A cloth with three vertices (one triangle) whose masses and terms a test sets itself.
inline std::unique_ptr<cloth::Cloth> triangle_cloth() {
  auto mesh = cloth::ClothMesh::from_triangles({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}, {{0, 1, 2}}, {},
                                               "test");
  return std::make_unique<cloth::Cloth>("test", mesh, cloth::Material());
}

inline Vec3s perturbed(const Vec3s& x, double amount, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-amount, amount);
  Vec3s out = x;
  for (Vec3& p : out) p += Vec3(u(rng), u(rng), u(rng));
  return out;
}

// A 4x3-node, 0.3 m x 0.2 m grid: small enough for dense finite-difference Jacobians.
inline std::shared_ptr<const cloth::ClothMesh> small_grid() {
  cloth::GridSpec g;
  g.size_u = 0.3;
  g.size_v = 0.2;
  g.nodes_u = 4;
  g.nodes_v = 3;
  return cloth::ClothMesh::grid(g);
}

// A 1 m cotton sheet of n x n nodes at height 1 m, 0.2 kg/m², two corners of one edge pinned.
inline cloth::SimulationSetup hanging_sheet(int n) {
  cloth::SimulationSetup s = loom::test::symplectic_setup();
  cloth::ClothSetup c;
  cloth::GridSpec g;
  g.nodes_u = g.nodes_v = n;
  g.origin = Vec3(-0.5, 1.0, -0.5);
  c.mesh = cloth::ClothMesh::grid(g);
  c.material = cloth::material_preset("cotton");
  c.material.areal_density = 0.2;
  c.pins = {cloth::PinSpec{c.mesh->grid_index(0, 0), {}, {}, {}},
            cloth::PinSpec{c.mesh->grid_index(n - 1, 0), {}, {}, {}}};
  s.cloths.push_back(c);
  return s;
}

// Finite-difference checks of a term (central differences, eps = 1e-6).
struct TermConfig {
  Vec3s x, v;
};

inline Vec3s term_forces(const cloth::Term& term, const Vec3s& x, const Vec3s& v, double t = 0.0) {
  Vec3s f(x.size(), Vec3::Zero());
  term.add_forces(cloth::EvalContext{x, v, t, 1}, f);
  return f;
}

inline double max_abs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

// The term's df/dx (wrt = 0) or df/dv (wrt = 1), dense.
inline Eigen::MatrixXd term_jacobian(const cloth::Term& term, const TermConfig& c, int wrt,
                                     const cloth::JacobianOptions& o = {}, double t = 0.0) {
  std::vector<std::pair<int, int>> pairs;
  term.add_pattern(pairs);
  cloth::BlockMatrix J(static_cast<int>(c.x.size()), pairs);
  term.add_jacobians(cloth::EvalContext{c.x, c.v, t, 1}, o, wrt == 0 ? &J : nullptr, wrt == 1 ? &J : nullptr);
  return J.to_dense();
}

// max |analytic - finite difference| / max |finite difference| of df/dx or df/dv.
inline double jacobian_error(const cloth::Term& term, const TermConfig& c, int wrt,
                             const cloth::JacobianOptions& o = {}, double t = 0.0) {
  const int n = static_cast<int>(c.x.size());
  const Eigen::MatrixXd analytic = term_jacobian(term, c, wrt, o, t);
  Eigen::MatrixXd fd(3 * n, 3 * n);
  const double eps = 1e-6;
  for (int j = 0; j < n; ++j)
    for (int d = 0; d < 3; ++d) {
      TermConfig plus = c, minus = c;
      (wrt == 0 ? plus.x : plus.v)[j][d] += eps;
      (wrt == 0 ? minus.x : minus.v)[j][d] -= eps;
      const Vec3s fp = term_forces(term, plus.x, plus.v, t), fm = term_forces(term, minus.x, minus.v, t);
      for (int i = 0; i < n; ++i) fd.block<3, 1>(3 * i, 3 * j + d) = (fp[i] - fm[i]) / (2 * eps);
    }
  return max_abs(analytic - fd) / std::max(max_abs(fd), 1e-300);
}

// max |f + dE/dx| / max |dE/dx| at rest velocities.
inline double gradient_error(const cloth::Term& term, const Vec3s& x) {
  const int n = static_cast<int>(x.size());
  const Vec3s v(n, Vec3::Zero());
  const Vec3s f = term_forces(term, x, v);
  double err = 0.0, scale = 0.0;
  const double eps = 1e-6;
  for (int j = 0; j < n; ++j)
    for (int d = 0; d < 3; ++d) {
      Vec3s xp = x, xm = x;
      xp[j][d] += eps;
      xm[j][d] -= eps;
      const double g =
          (term.energy(cloth::EvalContext{xp, v, 0, 1}) - term.energy(cloth::EvalContext{xm, v, 0, 1})) /
          (2 * eps);
      err = std::max(err, std::abs(f[j][d] + g));
      scale = std::max(scale, std::abs(g));
    }
  return err / scale;
}

}  // namespace loom::test
