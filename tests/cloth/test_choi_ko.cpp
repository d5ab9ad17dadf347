// Choi-Ko buckling springs: the exact circular-arc curve, its limits, energy/force/Jacobian consistency,
// and the resolution-independent, isotropic mapping of k_b from the bending rigidity B.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <random>

#include "loom/cloth/ChoiKoTerm.h"

namespace loom::cloth {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(ChoiKo, BucklingForceMatchesTheCircularArcCurve) {
  // Forward evaluation (no inversion): for arc half-angle y, l/L = sin y / y and
  // f = k_b (2y/L)² / (cos y - sin y / y). The term inverts l/L -> y; compare over l/L in [0.05, 1).
  const double L = 0.02, kb = 3e-6;
  double worst = 0.0;
  for (int k = 1; k < 4000; ++k) {
    const double y = kPi * k / 4000.0;
    const double ratio = std::sin(y) / y;
    if (ratio < 0.05) continue;
    const double exact = kb * (2 * y / L) * (2 * y / L) / (std::cos(y) - ratio);
    worst = std::max(worst, std::abs(choi_ko::buckling_force(ratio * L, L, kb) / exact - 1.0));
  }
  EXPECT_LT(worst, 1e-9);  // the acceptance bound is 0.5%; the evaluation is exact to round-off
}

TEST(ChoiKo, BucklingForceLimits) {
  const double L = 0.05, kb = 2e-6;
  EXPECT_NEAR(choi_ko::buckling_force(L * (1 - 1e-9), L, kb) / (-12 * kb / (L * L)), 1.0, 1e-6);
  EXPECT_NEAR(choi_ko::buckling_force(L * 1e-9, L, kb) / (-4 * kPi * kPi * kb / (L * L)), 1.0, 1e-6);
  // Monotone: f_b increases with l (df/dl > 0), so the buckling Jacobian never makes A indefinite.
  double prev = -1e300;
  for (int k = 1; k <= 1000; ++k) {
    const double l = L * k / 1000.0 * (1 - 1e-12);
    const double f = choi_ko::buckling_force(l, L, kb);
    EXPECT_GT(f, prev);
    EXPECT_GT(choi_ko::buckling_force_derivative(l, L, kb), 0.0);
    prev = f;
  }
}

TEST(ChoiKo, DerivativeAndEnergyAreConsistentWithTheForce) {
  const double L = 0.03, kb = 5e-6, h = 1e-7 * L;
  for (double x : {0.999, 0.99, 0.95, 0.8, 0.5, 0.2, 0.06}) {
    const double l = x * L;
    const double df =
        (choi_ko::buckling_force(l + h, L, kb) - choi_ko::buckling_force(l - h, L, kb)) / (2 * h);
    EXPECT_NEAR(choi_ko::buckling_force_derivative(l, L, kb) / df, 1.0, 1e-5) << "l/L = " << x;
    const double dE =
        (choi_ko::buckling_energy(l + h, L, kb) - choi_ko::buckling_energy(l - h, L, kb)) / (2 * h);
    EXPECT_NEAR(choi_ko::buckling_force(l, L, kb) / dE, 1.0, 1e-5) << "l/L = " << x;
  }
}

TEST(ChoiKo, LinearBranchRemovesTheForceJumpAndMeetsTheCurve) {
  GridSpec g;
  g.nodes_u = g.nodes_v = 33;
  auto mesh = ClothMesh::grid(g);
  auto term = make_choi_ko_term(*mesh, material_preset("cotton"));
  const BucklingSpring& s = term->interlaced().front();
  const double L = s.rest_length;
  EXPECT_EQ(term->interlaced_tension(s, L), 0.0);
  // Continuous at L: a 1e-12 compression gives a force 1e-6 of the curve's -12 k_b/L² (no jump).
  EXPECT_NEAR(term->interlaced_tension(s, L * (1 - 1e-12)), 0.0, 1e-6 * 12 * s.kb / (L * L));
  // ε* = (κ0 L)² / 24 with κ0 = 4 /m, and the crossover sits just past it: the curve is -12 k_b/L² (1 +
  // 0.6 δ) there, so 1 - l*/L = ε* / (1 - 0.6 ε*) to first order.
  const double eps = 16.0 * L * L / 24.0, xs = s.l_star / L;
  EXPECT_NEAR((1.0 - xs) / (eps / (1 - 0.6 * eps)), 1.0, 1e-3);
  EXPECT_NEAR(choi_ko::crossover_ratio(eps), xs, 1e-15);
  // Continuous at the crossover, and the exact curve beyond it.
  EXPECT_NEAR(
      term->interlaced_tension(s, xs * L * (1 + 1e-12)) / term->interlaced_tension(s, xs * L * (1 - 1e-12)),
      1.0, 1e-6);
  EXPECT_DOUBLE_EQ(term->interlaced_tension(s, 0.7 * L), choi_ko::buckling_force(0.7 * L, L, s.kb));
  // No compression resistance in type-1 springs; no tension in type-2 springs.
  EXPECT_EQ(term->interlaced_tension(s, 1.1 * L), 0.0);
}

TEST(ChoiKo, TermForcesAndJacobiansMatchFiniteDifferences) {
  GridSpec g;
  g.nodes_u = 5;
  g.nodes_v = 4;
  g.size_u = 0.08;
  g.size_v = 0.06;
  auto mesh = ClothMesh::grid(g);
  Material m = material_preset("cotton");
  m.bend_weft = m.bend_warp = 1e-3;  // make bending forces comparable to stretch for the check
  m.damping = 0.01;
  auto term = make_choi_ko_term(*mesh, m);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = mesh->num_vertices();
  for (int trial = 0; trial < 4; ++trial) {
    // Squeeze the sheet by 0-30% along u and wrinkle it: most interlaced springs deep in compression.
    const double squeeze = 1.0 - 0.1 * trial;
    Vec3s x = mesh->rest_positions(), v(n);
    for (int i = 0; i < n; ++i) {
      x[i].x() *= squeeze;
      x[i] += 0.004 * Vec3(u(rng), u(rng), u(rng));
      v[i] = Vec3(u(rng), u(rng), u(rng));
    }
    const double eps = 1e-7;
    // Force = -grad E (with v = 0 so damping is off).
    Vec3s zero(n, Vec3::Zero()), f(n, Vec3::Zero());
    term->add_forces(EvalContext{x, zero, 0, 1}, f);
    double err = 0, scale = 0;
    for (int i = 0; i < n; ++i)
      for (int d = 0; d < 3; ++d) {
        Vec3s xp = x, xm = x;
        xp[i][d] += eps;
        xm[i][d] -= eps;
        const double g =
            (term->energy(EvalContext{xp, zero, 0, 1}) - term->energy(EvalContext{xm, zero, 0, 1})) /
            (2 * eps);
        err = std::max(err, std::abs(f[i][d] + g));
        scale = std::max(scale, std::abs(g));
      }
    EXPECT_LT(err / scale, 1e-6) << "trial " << trial;
    // df/dx (exact mode) against central differences of the force.
    std::vector<std::pair<int, int>> pairs;
    term->add_pattern(pairs);
    BlockMatrix J(n, pairs);
    term->add_jacobians(EvalContext{x, v, 0, 1}, JacobianOptions{}, &J, nullptr);
    const Eigen::MatrixXd A = J.to_dense();
    Eigen::MatrixXd F(3 * n, 3 * n);
    for (int j = 0; j < n; ++j)
      for (int d = 0; d < 3; ++d) {
        Vec3s xp = x, xm = x, fp(n, Vec3::Zero()), fm(n, Vec3::Zero());
        xp[j][d] += eps;
        xm[j][d] -= eps;
        term->add_forces(EvalContext{xp, v, 0, 1}, fp);
        term->add_forces(EvalContext{xm, v, 0, 1}, fm);
        for (int i = 0; i < n; ++i) F.block<3, 1>(3 * i, 3 * j + d) = (fp[i] - fm[i]) / (2 * eps);
      }
    EXPECT_LT((A - F).cwiseAbs().maxCoeff() / F.cwiseAbs().maxCoeff(), 1e-6) << "trial " << trial;
    // The Choi-Ko Jacobian (clamped, no damping position terms) is symmetric negative semi-definite.
    BlockMatrix K(n, pairs);
    term->add_jacobians(EvalContext{x, v, 0, 1}, JacobianOptions{true, false}, &K, nullptr);
    const Eigen::MatrixXd Kd = K.to_dense();
    EXPECT_LT((Kd - Kd.transpose()).cwiseAbs().maxCoeff(), 1e-9 * Kd.cwiseAbs().maxCoeff());
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Kd);
    EXPECT_LT(eig.eigenvalues().maxCoeff(), 1e-9 * eig.eigenvalues().cwiseAbs().maxCoeff())
        << "trial " << trial;
  }
}

// A sheet of equilateral triangles (side d) in the XY plane centred on the origin, about `size` across.
std::shared_ptr<const ClothMesh> equilateral_sheet(int rows, double size) {
  const double d = size / (rows - 1), h = 0.5 * std::sqrt(3.0) * d;
  const int nu = static_cast<int>(std::lround(size / h)) + 1;
  Vec3s x;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < nu; ++i)
      x.push_back(Vec3(i * h - 0.5 * size, j * d + (i % 2 ? 0.5 * d : 0.0) - 0.5 * size, 0));
  std::vector<Tri> tris;
  for (int i = 0; i + 1 < nu; ++i)
    for (int j = 0; j + 1 < rows; ++j) {
      const int a = j * nu + i, b = j * nu + i + 1, c = (j + 1) * nu + i, e = (j + 1) * nu + i + 1;
      if (i % 2 == 0) {
        tris.push_back({a, b, c});
        tris.push_back({b, e, c});
      } else {
        tris.push_back({a, b, e});
        tris.push_back({a, e, c});
      }
    }
  return ClothMesh::from_triangles(std::move(x), std::move(tris), {}, "equilateral sheet");
}

// Bending energy of a flat sheet wrapped onto a cylinder of curvature κ whose bend direction makes angle φ
// with the weft, per unit (rest) area, over ½ B κ². Only the interlaced springs' bending part is summed:
// an arc-length wrap also shortens the sequential springs slightly, which the membrane part would count.
double bent_energy_ratio(std::shared_ptr<const ClothMesh> mesh, double kappa, double phi) {
  Material m = material_preset("cotton");
  m.bend_weft = m.bend_warp = 1e-4;
  auto term = make_choi_ko_term(*mesh, m);
  const Vec3 bend(std::cos(phi), std::sin(phi), 0), axis(-std::sin(phi), std::cos(phi), 0), normal(0, 0, 1);
  Vec3s x = mesh->rest_positions();
  for (Vec3& p : x) {
    const double s = p.dot(bend), t = p.dot(axis);  // arc length along the bend, position along the axis
    p = std::sin(kappa * s) / kappa * bend + t * axis + (1 - std::cos(kappa * s)) / kappa * normal;
  }
  double area = 0.0;
  const Vec3s& r = mesh->rest_positions();
  for (const Tri& t : mesh->triangles()) area += 0.5 * (r[t[1]] - r[t[0]]).cross(r[t[2]] - r[t[0]]).norm();
  return term->interlaced_bending_energy(x) / (0.5 * m.bend_weft * kappa * kappa * area);
}

std::shared_ptr<const ClothMesh> square_grid(int nodes) {
  const double size = 0.3;
  GridSpec g;
  g.nodes_u = g.nodes_v = nodes;
  g.size_u = g.size_v = size;
  g.plane = GridPlane::kXY;
  g.origin = Vec3(-size / 2, -size / 2, 0);
  return ClothMesh::grid(g);
}

TEST(ChoiKo, BendingEnergyIsResolutionIndependentAndIsotropic) {
  // Grids (warp, weft, both diagonals) and equilateral meshes (hinge pairs), gentle (κ = 2 /m: 50 cm radius)
  // and clear (κ = 20 /m) bends: the bending part has no linear branch, so gentle bends are not softer.
  // Boundary nodes have fewer interlaced springs, so a sheet stores slightly less than ½ B κ² per area.
  for (const double kappa : {2.0, 20.0}) {
    const double coarse = bent_energy_ratio(square_grid(61), kappa, 0.0),
                 fine = bent_energy_ratio(square_grid(121), kappa, 0.0);
    const double diagonal = bent_energy_ratio(square_grid(121), kappa, kPi / 4);
    const double oblique = bent_energy_ratio(square_grid(121), kappa, kPi / 8);
    EXPECT_GT(fine, 0.95) << "κ " << kappa;
    EXPECT_LT(fine, 1.03) << "κ " << kappa;
    EXPECT_LT(std::abs(coarse - fine) / fine, 0.03) << "61 nodes: " << coarse << ", 121 nodes: " << fine;
    EXPECT_LT(std::abs(diagonal - fine) / fine, 0.05) << "0°: " << fine << ", 45°: " << diagonal;
    EXPECT_LT(std::abs(oblique - fine) / fine, 0.05) << "0°: " << fine << ", 22.5°: " << oblique;
    const double mesh_coarse = bent_energy_ratio(equilateral_sheet(41, 0.3), kappa, 0.0);
    const double mesh_fine = bent_energy_ratio(equilateral_sheet(81, 0.3), kappa, 0.0);
    const double mesh_30 = bent_energy_ratio(equilateral_sheet(81, 0.3), kappa, kPi / 6);
    const double mesh_90 = bent_energy_ratio(equilateral_sheet(81, 0.3), kappa, kPi / 2);
    std::printf(
        "κ %.0f /m: grid 61/121 nodes %.4f %.4f, 22.5° %.4f, 45° %.4f; equilateral 41/81 rows %.4f %.4f, 30° "
        "%.4f, 90° %.4f\n",
        kappa, coarse, fine, oblique, diagonal, mesh_coarse, mesh_fine, mesh_30, mesh_90);
    EXPECT_GT(mesh_fine, 0.95) << "κ " << kappa;
    EXPECT_LT(mesh_fine, 1.03) << "κ " << kappa;
    EXPECT_LT(std::abs(mesh_coarse - mesh_fine) / mesh_fine, 0.03);
    EXPECT_LT(std::abs(mesh_30 - mesh_fine) / mesh_fine, 0.05);
    EXPECT_LT(std::abs(mesh_90 - mesh_fine) / mesh_fine, 0.05);
  }
}

}  // namespace
}  // namespace loom::cloth
