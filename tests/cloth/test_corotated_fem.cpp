// Co-rotated linear FEM membrane: force = -grad E, exact Jacobians against central finite
// differences, the solvers' co-rotational stiffness (symmetric, negative semi-definite, exact at zero
// strain), rigid rotations of a stretched sheet, patch tests for the warp, weft and shear moduli on an
// irregular mesh, and the model under implicit_euler.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <random>

#include "TestUtil.h"
#include "loom/cloth/CorotatedFemTerm.h"
#include "loom/cloth/Model.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

using test::max_abs;
using test::perturbed;
using test::small_grid;
using Config = test::TermConfig;

Material fem_material(double damping) {
  Material m;
  m.stretch_weft = 1500.0;
  m.stretch_warp = 900.0;
  m.shear = 80.0;
  m.damping = damping;
  return m;
}

// A flat 0.6 m x 0.4 m sheet in the xz plane, 7 x 5 nodes, interior nodes jittered in the plane (irregular
// triangles), weft along x and warp along z (texture coordinates = (x, z)).
std::shared_ptr<const ClothMesh> irregular_flat_mesh(std::mt19937& rng) {
  GridSpec g;
  g.size_u = 0.6;
  g.size_v = 0.4;
  g.nodes_u = 7;
  g.nodes_v = 5;
  auto grid = ClothMesh::grid(g);
  Vec3s x = grid->rest_positions();
  std::uniform_real_distribution<double> u(-0.03, 0.03);
  for (int iv = 1; iv + 1 < g.nodes_v; ++iv)
    for (int iu = 1; iu + 1 < g.nodes_u; ++iu) {
      Vec3& p = x[grid->grid_index(iu, iv)];
      p.x() += u(rng);
      p.z() += u(rng);
    }
  std::vector<std::array<Vec2, 3>> uvs;
  for (const Tri& t : grid->triangles())
    uvs.push_back(
        {Vec2(x[t[0]].x(), x[t[0]].z()), Vec2(x[t[1]].x(), x[t[1]].z()), Vec2(x[t[2]].x(), x[t[2]].z())});
  return ClothMesh::from_triangles(x, grid->triangles(), uvs, "test");
}

// A non-flat irregular mesh (random rest shape, PCA frames).
std::shared_ptr<const ClothMesh> curved_mesh(std::mt19937& rng) {
  auto g = small_grid();
  return ClothMesh::from_triangles(perturbed(g->rest_positions(), 0.02, rng), g->triangles(), {}, "test");
}

double max_norm(const Vec3s& f) {
  double m = 0.0;
  for (const Vec3& v : f) m = std::max(m, v.norm());
  return m;
}

TEST(CorotatedFem, ForcesAreMinusEnergyGradient) {
  std::mt19937 rng(21);
  for (int kind = 0; kind < 2; ++kind) {
    auto mesh = kind == 0 ? small_grid() : curved_mesh(rng);
    auto term = make_corotated_fem_term(*mesh, fem_material(0.0));
    for (int trial = 0; trial < 4; ++trial) {
      const Vec3s x = perturbed(mesh->rest_positions(), 0.03, rng);
      EXPECT_LT(test::gradient_error(*term, x), 1e-6) << "mesh " << kind << " trial " << trial;
    }
  }
}

TEST(CorotatedFem, ExactJacobiansMatchFiniteDifferences) {
  std::mt19937 rng(22);
  JacobianOptions exact;  // clamp_compression = false, damping_position_terms = true
  for (int kind = 0; kind < 2; ++kind) {
    auto mesh = kind == 0 ? small_grid() : curved_mesh(rng);
    auto term = make_corotated_fem_term(*mesh, fem_material(0.01));
    for (int trial = 0; trial < 4; ++trial) {
      Config c{perturbed(mesh->rest_positions(), 0.03, rng),
               perturbed(Vec3s(mesh->num_vertices(), Vec3::Zero()), 1.0, rng)};
      EXPECT_LT(test::jacobian_error(*term, c, 0, exact), 1e-6) << "df/dx, mesh " << kind;
      EXPECT_LT(test::jacobian_error(*term, c, 1, exact), 1e-6) << "df/dv, mesh " << kind;
    }
  }
}

TEST(CorotatedFem, SolverStiffnessIsSymmetricNegativeSemiDefiniteAndExactAtZeroStrain) {
  // Both solver stiffnesses: the projected exact Hessian (default) and the standard co-rotational -R K₀ Rᵀ.
  for (bool corotational_only : {false, true}) {
    SCOPED_TRACE(corotational_only ? "-R K0 R^T" : "projected Hessian");
    std::mt19937 rng(23);
    auto mesh = small_grid();
    auto term = make_corotated_fem_term(*mesh, fem_material(0.01));
    static_cast<CorotatedFemTerm&>(*term).set_corotational_only(corotational_only);
    JacobianOptions solver;
    solver.clamp_compression = true;
    solver.damping_position_terms = false;
    const Mat3 R = Eigen::AngleAxisd(1.1, Vec3(0.2, 1.0, -0.6).normalized()).toRotationMatrix();
    for (int trial = 0; trial < 3; ++trial) {
      Config c{perturbed(mesh->rest_positions(), 0.03, rng),
               perturbed(Vec3s(mesh->num_vertices(), Vec3::Zero()), 1.0, rng)};
      for (Vec3& p : c.x) p *= trial == 0 ? 0.85 : 1.1;  // compressed, stretched
      for (int wrt = 0; wrt < 2; ++wrt) {
        const Eigen::MatrixXd K = test::term_jacobian(*term, c, wrt, solver);
        EXPECT_LT(max_abs(K - K.transpose()), 1e-12 * max_abs(K));
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(K);
        EXPECT_LT(eig.eigenvalues().maxCoeff(), 1e-9 * eig.eigenvalues().cwiseAbs().maxCoeff());
      }
    }
    // Zero strain, any rotation and translation: the co-rotational stiffness is the exact Hessian.
    Config rest{mesh->rest_positions(), Vec3s(mesh->num_vertices(), Vec3::Zero())};
    for (Vec3& p : rest.x) p = R * p + Vec3(0.3, -1.0, 2.0);
    EXPECT_LT(test::jacobian_error(*term, rest, 0, solver), 1e-6);
    // Small strain (1e-4, stretched along x and compressed along z): -R K₀ Rᵀ differs from the exact Hessian
    // by O(strain); the projection only removes the compression's negative curvature, also O(strain).
    Config small = rest;
    for (Vec3& p : small.x) p = R * (R.transpose() * p).cwiseProduct(Vec3(1.0 + 1e-4, 1.0, 1.0 - 5e-5));
    const double err = test::jacobian_error(*term, small, 0, solver);
    EXPECT_LT(err, 1e-3);
    EXPECT_GT(err, 0.0);
    if (!corotational_only) {
      // Stretched only: the exact Hessian is already negative semi-definite, the projection leaves it exact.
      Config stretched = rest;
      for (Vec3& p : stretched.x) p = R * (R.transpose() * p).cwiseProduct(Vec3(1.05, 1.0, 1.02));
      EXPECT_LT(test::jacobian_error(*term, stretched, 0, solver), 1e-6);
    }
  }
}

TEST(CorotatedFem, RigidRotationsOfAStretchedSheetGiveNoSpuriousForce) {
  std::mt19937 rng(24);
  auto mesh = irregular_flat_mesh(rng);
  auto term = make_corotated_fem_term(*mesh, fem_material(0.0));
  const int n = mesh->num_vertices();
  const Vec3s zero(n, Vec3::Zero());
  // Stretched 4% along the weft, 2% along the warp, sheared a little: its own forces f0.
  Vec3s x0 = mesh->rest_positions();
  for (Vec3& p : x0) p = Vec3(1.04 * p.x() + 0.01 * p.z(), p.y(), 1.02 * p.z());
  const Vec3s f0 = test::term_forces(*term, x0, zero);
  const double scale = max_norm(f0);
  ASSERT_GT(scale, 1.0);
  for (int trial = 0; trial < 5; ++trial) {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const Mat3 R =
        Eigen::AngleAxisd(3.0 * u(rng), Vec3(u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
    const Vec3 shift(u(rng), u(rng), u(rng));
    Vec3s x(n), xr(n);
    for (int i = 0; i < n; ++i) {
      x[i] = R * x0[i] + shift;
      xr[i] = R * mesh->rest_positions()[i] + shift;
    }
    // The stretched sheet's forces turn with it: nothing else appears.
    const Vec3s f = test::term_forces(*term, x, zero);
    Vec3 net = Vec3::Zero(), torque = Vec3::Zero();
    double err = 0.0;
    for (int i = 0; i < n; ++i) {
      err = std::max(err, (f[i] - R * f0[i]).norm());
      net += f[i];
      torque += (x[i] - shift).cross(f[i]);
    }
    if (trial == 0) std::printf("rotated stretched sheet: |f(Qx) - Q f(x)| / max|f| = %.2g\n", err / scale);
    EXPECT_LT(err, 1e-9 * scale) << "trial " << trial;
    EXPECT_LT(net.norm(), 1e-9 * scale);
    EXPECT_LT(torque.norm(), 1e-9 * scale);
    EXPECT_NEAR(term->energy(EvalContext{x, zero, 0, 1}), term->energy(EvalContext{x0, zero, 0, 1}),
                1e-9 * term->energy(EvalContext{x0, zero, 0, 1}));
    // The unstretched sheet, rotated: no force, no energy.
    EXPECT_LT(max_norm(test::term_forces(*term, xr, zero)), 1e-9 * scale);
    EXPECT_LT(term->energy(EvalContext{xr, zero, 0, 1}), 1e-18);
  }
}

// Patch test on the irregular mesh: a uniform strain must give zero force on every interior node and the
// material's modulus as traction on the boundary.
TEST(CorotatedFem, PatchTestGivesTheWarpWeftAndShearModuli) {
  std::mt19937 rng(25);
  auto mesh = irregular_flat_mesh(rng);
  const Material m = fem_material(0.0);
  auto term = make_corotated_fem_term(*mesh, m);
  const int n = mesh->num_vertices();
  const Vec3s zero(n, Vec3::Zero());
  const double W = 0.6, H = 0.4, area = W * H, eps = 0.02;
  auto on = [](double a, double b) { return std::abs(a - b) < 1e-12; };
  for (int dir = 0; dir < 2; ++dir) {  // 0: weft (x), 1: warp (z)
    Vec3s x = mesh->rest_positions();
    for (Vec3& p : x) (dir == 0 ? p.x() : p.z()) *= 1.0 + eps;
    const Vec3s f = test::term_forces(*term, x, zero);
    double pull = 0.0, interior = 0.0;
    for (int i = 0; i < n; ++i) {
      const Vec3& X = mesh->rest_positions()[i];
      const bool boundary = on(X.x(), 0) || on(X.x(), W) || on(X.z(), 0) || on(X.z(), H);
      if (!boundary) interior = std::max(interior, f[i].norm());
      if (on(dir == 0 ? X.x() : X.z(), dir == 0 ? W : H)) pull -= dir == 0 ? f[i].x() : f[i].z();
    }
    const double edge = dir == 0 ? H : W;
    const double modulus = pull / (eps * edge);  // N/m
    const double expect = dir == 0 ? m.stretch_weft : m.stretch_warp;
    std::printf(
        "patch test %s: modulus %.6f N/m (material %.1f, rel. error %.2g), max interior force %.2g N\n",
        dir == 0 ? "weft" : "warp", modulus, expect, std::abs(modulus / expect - 1.0), interior);
    EXPECT_NEAR(modulus, expect, 0.005 * expect) << "dir " << dir;
    EXPECT_LT(interior, 1e-9 * pull) << "dir " << dir;
    EXPECT_NEAR(term->energy(EvalContext{x, zero, 0, 1}), 0.5 * expect * area * eps * eps,
                0.005 * 0.5 * expect * area * eps * eps);
  }
  // Simple shear x += γ z: the shear modulus from the energy 1/2 G γ² A and from the traction on the top edge
  // (force along x per metre of edge = G γ).
  const double gamma = 0.01;
  Vec3s x = mesh->rest_positions();
  for (Vec3& p : x) p.x() += gamma * p.z();
  const double e = term->energy(EvalContext{x, zero, 0, 1});
  EXPECT_NEAR(e / (0.5 * gamma * gamma * area), m.shear, 0.005 * m.shear);
  const Vec3s f = test::term_forces(*term, x, zero);
  double shear_pull = 0.0;
  for (int i = 0; i < n; ++i)
    if (on(mesh->rest_positions()[i].z(), H)) shear_pull -= f[i].x();
  std::printf("patch test shear: G from energy %.5f N/m, from traction %.5f N/m (material %.1f)\n",
              e / (0.5 * gamma * gamma * area), shear_pull / (gamma * W), m.shear);
  EXPECT_NEAR(shear_pull / (gamma * W), m.shear, 0.005 * m.shear);
}

TEST(CorotatedFem, ModelIsRegistered) {
  auto c = std::make_unique<Cloth>("c", small_grid(), fem_material(0.0));
  add_model_terms(*c, "corotated_fem", "", "model");
  ASSERT_EQ(c->terms().size(), 2u);
  EXPECT_STREQ(c->terms()[0]->name(), "corotated_fem");
  EXPECT_STREQ(c->terms()[1]->name(), "dihedral_bending");
}

TEST(CorotatedFem, HangsUnderImplicitEulerAtOneStepPerFrame) {
  // The hanging sheet (17 x 17, cotton) with the FEM model, backward Euler at 60 Hz, one step per frame,
  // 1.5 s: it stays finite, falls and swings, and its membrane stays within a few percent of stretch.
  SimulationSetup s = test::hanging_sheet(17);
  s.cloths[0].model = "corotated_fem";
  s.solver.method = "implicit_euler";
  s.substeps = 1;
  Simulation sim(s);
  const double y0 = [&] {
    double y = 0.0;
    for (const Vec3& p : sim.cloths()[0]->state().x) y += p.y();
    return y / sim.cloths()[0]->state().size();
  }();
  double max_strain = 0.0;
  FrameStats st;
  for (int f = 0; f < 90; ++f) {
    st = sim.step_frame();
    ASSERT_TRUE(st.finite) << "frame " << f;
    max_strain = std::max(max_strain, st.max_strain);
  }
  double y = 0.0;
  for (const Vec3& p : sim.cloths()[0]->state().x) y += p.y();
  y /= sim.cloths()[0]->state().size();
  EXPECT_LT(y, y0 - 0.2);  // it fell: the centre of mass of the settled hanging sheet is ~0.5 m lower
  EXPECT_LT(max_strain, 0.05);
  EXPECT_GT(st.elastic, 0.0);
}

}  // namespace
}  // namespace loom::cloth
