// Baraff-Witkin stretch/shear and dihedral bending: force = -grad E and Jacobians against central finite
// differences (< 1e-6 relative) on random configurations, rigid motions give zero force, uniform stretch
// gives the modulus, a cylinder gives 1/2 B κ² per unit area with the right directional B.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

#include "TestUtil.h"
#include "loom/cloth/BaraffWitkinTerm.h"
#include "loom/cloth/DihedralBendingTerm.h"
#include "loom/cloth/Model.h"

namespace loom::cloth {
namespace {

using test::perturbed;

using Config = test::TermConfig;
using test::gradient_error;
using test::jacobian_error;
using test::max_abs;
using test::small_grid;

// An irregular, non-flat mesh: a grid with jittered rest positions (PCA frames, non-zero rest angles).
std::shared_ptr<const ClothMesh> irregular_mesh(std::mt19937& rng) {
  auto g = small_grid();
  return ClothMesh::from_triangles(perturbed(g->rest_positions(), 0.02, rng), g->triangles(), {}, "test");
}

Material test_material(double damping) {
  Material m;
  m.stretch_weft = 1500.0;
  m.stretch_warp = 900.0;
  m.shear = 80.0;
  m.bend_weft = 2e-5;
  m.bend_warp = 5e-5;
  m.damping = damping;
  return m;
}

std::vector<std::unique_ptr<Term>> all_terms(const ClothMesh& mesh, const Material& m) {
  std::vector<std::unique_ptr<Term>> t;
  t.push_back(make_bw_stretch_term(mesh, m));
  t.push_back(make_bw_shear_term(mesh, m));
  t.push_back(make_dihedral_bending_term(mesh, m));
  return t;
}

TEST(BaraffWitkin, ForcesAreMinusEnergyGradient) {
  std::mt19937 rng(11);
  for (int mesh_kind = 0; mesh_kind < 2; ++mesh_kind) {
    auto mesh = mesh_kind == 0 ? small_grid() : irregular_mesh(rng);
    for (const auto& term : all_terms(*mesh, test_material(0.0)))
      for (int trial = 0; trial < 4; ++trial) {
        const Vec3s x = perturbed(mesh->rest_positions(), 0.03, rng);
        EXPECT_LT(gradient_error(*term, x), 1e-6)
            << term->name() << " mesh " << mesh_kind << " trial " << trial;
      }
  }
}

TEST(BaraffWitkin, ExactJacobiansMatchFiniteDifferences) {
  std::mt19937 rng(12);
  JacobianOptions exact;  // clamp_compression = false, damping_position_terms = true
  for (int mesh_kind = 0; mesh_kind < 2; ++mesh_kind) {
    auto mesh = mesh_kind == 0 ? small_grid() : irregular_mesh(rng);
    for (const auto& term : all_terms(*mesh, test_material(0.01)))
      for (int trial = 0; trial < 4; ++trial) {
        Config c{perturbed(mesh->rest_positions(), 0.03, rng),
                 perturbed(Vec3s(mesh->num_vertices(), Vec3::Zero()), 1.0, rng)};
        EXPECT_LT(jacobian_error(*term, c, 0, exact), 1e-6) << term->name() << " df/dx, mesh " << mesh_kind;
        EXPECT_LT(jacobian_error(*term, c, 1, exact), 1e-6) << term->name() << " df/dv, mesh " << mesh_kind;
      }
  }
}

TEST(BaraffWitkin, SolverJacobiansAreSymmetricNegativeSemiDefinite) {
  // What implicit solvers request: clamp_compression (stretch clamp, shear and bending Gauss-Newton) and
  // no damping position terms. Under compression and bending the exact K is indefinite, these are not.
  std::mt19937 rng(13);
  auto mesh = small_grid();
  JacobianOptions solver_opts;
  solver_opts.clamp_compression = true;
  solver_opts.damping_position_terms = false;
  for (const auto& term : all_terms(*mesh, test_material(0.01)))
    for (int trial = 0; trial < 3; ++trial) {
      Config c{perturbed(mesh->rest_positions(), 0.03, rng),
               perturbed(Vec3s(mesh->num_vertices(), Vec3::Zero()), 1.0, rng)};
      for (Vec3& p : c.x) p *= 0.85;  // compressed
      for (int wrt = 0; wrt < 2; ++wrt) {
        const Eigen::MatrixXd K = test::term_jacobian(*term, c, wrt, solver_opts);
        EXPECT_LT(max_abs(K - K.transpose()), 1e-12 * max_abs(K)) << term->name();
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(K);
        EXPECT_LT(eig.eigenvalues().maxCoeff(), 1e-9 * eig.eigenvalues().cwiseAbs().maxCoeff())
            << term->name();
      }
      if (std::string(term->name()) != "bw_stretch") {
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(
            test::term_jacobian(*term, c, 0, JacobianOptions{}));
        EXPECT_GT(eig.eigenvalues().maxCoeff(), 1e-6 * eig.eigenvalues().cwiseAbs().maxCoeff())
            << term->name();
      }
    }
}

TEST(BaraffWitkin, GaussNewtonBendingJacobianIsExactAtRest) {
  std::mt19937 rng(14);
  auto mesh = irregular_mesh(rng);  // non-zero rest angles
  auto bend = make_dihedral_bending_term(*mesh, test_material(0.0));
  Config c{mesh->rest_positions(), Vec3s(mesh->num_vertices(), Vec3::Zero())};
  JacobianOptions gn;
  gn.clamp_compression = true;
  EXPECT_LT(
      max_abs(test::term_jacobian(*bend, c, 0, gn) - test::term_jacobian(*bend, c, 0, JacobianOptions{})),
      1e-12);
  EXPECT_LT(jacobian_error(*bend, c, 0, gn), 1e-6);
}

TEST(BaraffWitkin, RigidMotionsGiveZeroForceAndEnergy) {
  std::mt19937 rng(15);
  auto mesh = irregular_mesh(rng);
  const Material m = test_material(0.01);
  const Mat3 R = Eigen::AngleAxisd(0.9, Vec3(0.3, -1.0, 0.4).normalized()).toRotationMatrix();
  const Vec3 shift(0.7, -2.0, 1.3), omega(0.5, 1.0, -2.0);
  Vec3s x(mesh->num_vertices()), v(mesh->num_vertices());
  for (int i = 0; i < mesh->num_vertices(); ++i) {
    x[i] = R * mesh->rest_positions()[i] + shift;
    v[i] = Vec3(0.3, 0.2, -0.1) + omega.cross(x[i]);  // rigid velocity: no strain rate, no damping force
  }
  for (const auto& term : all_terms(*mesh, m)) {
    const Vec3s f = test::term_forces(*term, x, v);
    double fmax = 0.0;
    for (const Vec3& fi : f) fmax = std::max(fmax, fi.norm());
    EXPECT_LT(fmax, 1e-9) << term->name();
    EXPECT_LT(term->energy(EvalContext{x, v, 0, 1}), 1e-18) << term->name();
  }
}

TEST(BaraffWitkin, UniformStretchGivesTheModulus) {
  GridSpec g;
  g.size_u = 0.6;
  g.size_v = 0.4;
  g.nodes_u = 7;
  g.nodes_v = 5;
  auto mesh = ClothMesh::grid(g);
  const Material m = test_material(0.0);
  auto stretch = make_bw_stretch_term(*mesh, m);
  auto shear = make_bw_shear_term(*mesh, m);
  const double eps = 0.05;
  for (int dir = 0; dir < 2; ++dir) {  // 0: along weft (x), 1: along warp (z)
    Vec3s x = mesh->rest_positions();
    for (Vec3& p : x) (dir == 0 ? p.x() : p.z()) *= 1.0 + eps;
    const Vec3s v(x.size(), Vec3::Zero());
    const double k = dir == 0 ? m.stretch_weft : m.stretch_warp;
    const double area = g.size_u * g.size_v;
    // E = k/2 A ε² with α = sqrt(A): the 2D modulus, whatever the resolution.
    EXPECT_NEAR(stretch->energy(EvalContext{x, v, 0, 1}), 0.5 * k * area * eps * eps, 1e-12);
    EXPECT_NEAR(shear->energy(EvalContext{x, v, 0, 1}), 0.0, 1e-15);
    // Traction: the nodes of the far edge are pulled back with k ε per metre of edge.
    const Vec3s f = test::term_forces(*stretch, x, v);
    double pull = 0.0;
    for (int iv = 0; iv < g.nodes_v; ++iv)
      for (int iu = 0; iu < g.nodes_u; ++iu)
        if ((dir == 0 ? iu : iv) == (dir == 0 ? g.nodes_u : g.nodes_v) - 1)
          pull += dir == 0 ? f[mesh->grid_index(iu, iv)].x() : f[mesh->grid_index(iu, iv)].z();
    const double edge = dir == 0 ? g.size_v : g.size_u;
    EXPECT_NEAR(pull, -k * eps * edge, 1e-9 * k);
  }
}

TEST(BaraffWitkin, ShearingGivesTheShearModulus) {
  GridSpec g;
  g.nodes_u = 6;
  g.nodes_v = 6;
  auto mesh = ClothMesh::grid(g);
  const Material m = test_material(0.0);
  auto shear = make_bw_shear_term(*mesh, m);
  const double gamma = 0.01;  // simple shear x += γ z: w_u·w_v = γ
  Vec3s x = mesh->rest_positions();
  for (Vec3& p : x) p.x() += gamma * p.z();
  const double area = g.size_u * g.size_v;
  EXPECT_NEAR(shear->energy(EvalContext{x, Vec3s(x.size(), Vec3::Zero()), 0, 1}),
              0.5 * m.shear * area * gamma * gamma, 1e-12);
}

TEST(BaraffWitkin, CylinderBendingEnergyUsesTheDirectionalRigidity) {
  // A 33x33 grid rolled on a cylinder of curvature κ, axis along warp (curvature along the weft) or
  // along weft: E = 1/2 B κ² A for axis-aligned bends (Bridson, Marino & Fedkiw 2003; docs/references.md).
  GridSpec g;
  g.nodes_u = 33;
  g.nodes_v = 33;
  g.plane = GridPlane::kXZ;
  auto mesh = ClothMesh::grid(g);
  const Material m = test_material(0.0);
  auto bend = make_dihedral_bending_term(*mesh, m);
  const double kappa = 2.0;  // 1/m
  for (int dir = 0; dir < 2; ++dir) {
    Vec3s x = mesh->rest_positions();
    for (Vec3& p : x) {
      double& s = dir == 0 ? p.x() : p.z();
      const double arc = s;
      s = std::sin(kappa * arc) / kappa;
      p.y() = (1.0 - std::cos(kappa * arc)) / kappa;
    }
    const double B = dir == 0 ? m.bend_weft : m.bend_warp;
    const double expect = 0.5 * B * kappa * kappa * g.size_u * g.size_v;
    // Only interior hinges carry energy: the bent strip loses one column of cells, (N-2)/(N-1).
    EXPECT_NEAR(bend->energy(EvalContext{x, Vec3s(x.size(), Vec3::Zero()), 0, 1}), expect * 31.0 / 32.0,
                0.01 * expect)
        << "dir " << dir;
  }
}

TEST(BaraffWitkin, ModelIsRegistered) {
  auto c = std::make_unique<Cloth>("c", small_grid(), test_material(0.0));
  add_model_terms(*c, "baraff_witkin", "", "model");
  ASSERT_EQ(c->terms().size(), 3u);
  EXPECT_STREQ(c->terms()[0]->name(), "bw_stretch");
  EXPECT_STREQ(c->terms()[1]->name(), "bw_shear");
  EXPECT_STREQ(c->terms()[2]->name(), "dihedral_bending");
}

}  // namespace
}  // namespace loom::cloth
