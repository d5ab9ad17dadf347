// Every term: force = -grad(energy) and Jacobians = derivatives of the force, by central finite differences
// on random configurations (relative error < 1e-6).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <functional>
#include <random>

#include "TestUtil.h"
#include "loom/cloth/AirDragTerm.h"
#include "loom/cloth/GravityTerm.h"
#include "loom/cloth/Model.h"
#include "loom/cloth/SpringSet.h"
#include "loom/cloth/SpringTerm.h"

namespace loom::cloth {
namespace {

using test::perturbed;

using Config = test::TermConfig;
using test::gradient_error;
using test::jacobian_error;
using test::max_abs;
using test::small_grid;

Config random_config(const ClothMesh& mesh, double amount, std::mt19937& rng) {
  Config c;
  c.x = perturbed(mesh.rest_positions(), amount, rng);
  c.v = perturbed(Vec3s(mesh.num_vertices(), Vec3::Zero()), 1.0, rng);
  return c;
}

TEST(Jacobians, SpringForceIsMinusEnergyGradient) {
  std::mt19937 rng(1);
  auto mesh = small_grid();
  Material m = material_preset("cotton");
  SpringTerm springs(mesh->num_vertices(), make_springs(*mesh, m));
  for (int trial = 0; trial < 5; ++trial) {
    Config c = random_config(*mesh, 0.02, rng);
    c.v.assign(c.v.size(), Vec3::Zero());  // the conservative part only
    EXPECT_LT(gradient_error(springs, c.x), 1e-6) << "trial " << trial;
  }
}

TEST(Jacobians, SpringJacobiansMatchFiniteDifferences) {
  std::mt19937 rng(2);
  auto mesh = small_grid();
  Material m = material_preset("cotton");
  m.damping = 0.01;  // exercise the damping blocks too
  SpringTerm springs(mesh->num_vertices(), make_springs(*mesh, m));
  for (int trial = 0; trial < 5; ++trial) {
    const Config c = random_config(*mesh, 0.03, rng);  // mixes stretched and compressed springs
    EXPECT_LT(jacobian_error(springs, c, 0), 1e-6) << "df/dx, trial " << trial;
    EXPECT_LT(jacobian_error(springs, c, 1), 1e-6) << "df/dv, trial " << trial;
  }
}

TEST(Jacobians, ClampedSpringJacobianIsExactInTensionAndSemiDefiniteAlways) {
  std::mt19937 rng(3);
  auto mesh = small_grid();
  Material m = material_preset("cotton");
  std::vector<Spring> s = make_springs(*mesh, m);
  // Tension everywhere: scale the rest shape up by 5% (plus noise below that).
  Config c;
  c.x = perturbed(mesh->rest_positions(), 1e-4, rng);
  for (Vec3& p : c.x) p *= 1.05;
  c.v.assign(c.x.size(), Vec3::Zero());
  SpringTerm springs(mesh->num_vertices(), s);
  JacobianOptions clamped;
  clamped.clamp_compression = true;
  EXPECT_LT(jacobian_error(springs, c, 0, clamped), 1e-6);
  // Under compression the clamped K stays negative semi-definite (so M - h²K is positive definite).
  Config squeezed = random_config(*mesh, 0.0, rng);
  for (Vec3& p : squeezed.x) p *= 0.8;
  std::vector<std::pair<int, int>> pairs;
  springs.add_pattern(pairs);
  BlockMatrix K(mesh->num_vertices(), pairs);
  springs.add_jacobians(EvalContext{squeezed.x, squeezed.v, 0, 1}, clamped, &K, nullptr);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(K.to_dense());
  EXPECT_LT(eig.eigenvalues().maxCoeff(), 1e-9 * eig.eigenvalues().cwiseAbs().maxCoeff());
  // ...while the exact K has positive eigenvalues there (the indefiniteness the clamp removes).
  BlockMatrix exact(mesh->num_vertices(), pairs);
  springs.add_jacobians(EvalContext{squeezed.x, squeezed.v, 0, 1}, JacobianOptions{}, &exact, nullptr);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig2(exact.to_dense());
  EXPECT_GT(eig2.eigenvalues().maxCoeff(), 1.0);
}

TEST(Jacobians, GravityForceIsMinusEnergyGradientAndJacobianIsZero) {
  std::mt19937 rng(4);
  auto mesh = small_grid();
  std::vector<double> mass(mesh->num_vertices());
  for (size_t i = 0; i < mass.size(); ++i) mass[i] = 0.01 + 0.001 * i;
  GravityTerm g(mass, Vec3(0.3, -9.81, 0.1));
  const Config c = random_config(*mesh, 0.05, rng);
  EXPECT_LT(gradient_error(g, c.x), 1e-6);
  std::vector<std::pair<int, int>> pairs;
  BlockMatrix J(mesh->num_vertices(), pairs);
  g.add_jacobians(EvalContext{c.x, c.v, 0, 1}, {}, &J, &J);
  EXPECT_EQ(max_abs(J.to_dense()), 0.0);
}

TEST(Jacobians, AirDragJacobiansMatchFiniteDifferences) {
  std::mt19937 rng(5);
  auto mesh = small_grid();
  DragSettings d;
  d.isotropic = 0.3;
  d.normal = 1.7;
  d.wind = Vec3(4.0, 0.5, -1.0);
  d.gust_amplitude = 0.3;
  d.gust_frequency = 0.9;
  AirDragTerm drag(d, mesh->triangles(), mesh->vertex_areas());
  for (int trial = 0; trial < 5; ++trial) {
    const Config c = random_config(*mesh, 0.05, rng);
    const double t = 0.37 * trial;
    EXPECT_LT(jacobian_error(drag, c, 0, {}, t), 1e-6) << "df/dx, trial " << trial;
    EXPECT_LT(jacobian_error(drag, c, 1, {}, t), 1e-6) << "df/dv, trial " << trial;
  }
}

TEST(Jacobians, AirDragOpposesRelativeMotion) {
  auto mesh = small_grid();
  DragSettings d;
  d.isotropic = 0.5;
  d.normal = 2.0;
  AirDragTerm drag(d, mesh->triangles(), mesh->vertex_areas());
  Vec3s v(mesh->num_vertices(), Vec3(0.2, -1.0, 0.3));
  const Vec3s f = test::term_forces(drag, mesh->rest_positions(), v);
  double power = 0.0;
  for (size_t i = 0; i < f.size(); ++i) power += f[i].dot(v[i]);
  EXPECT_LT(power, 0.0);  // drag only dissipates
}

}  // namespace
}  // namespace loom::cloth

namespace loom::cloth {
namespace {

using test::perturbed;

TEST(Energies, ChunkedSumIsTheSerialSumUpToOneChunkAndThreadIndependent) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> v(5000);
  for (double& a : v) a = u(rng) * std::exp(10.0 * u(rng));  // magnitudes over 9 decades: order matters
  const auto term = [&](int k) { return v[k]; };
  double serial = 0.0;
  for (int k = 0; k < 512; ++k) serial += v[k];
  EXPECT_EQ(chunked_sum(512, 2, term), serial);  // one chunk: the serial loop, bit for bit
  long double exact = 0.0L;
  for (double a : v) exact += a;
  const double one = chunked_sum(5000, 1, term), two = chunked_sum(5000, 2, term);
  EXPECT_EQ(one, two);
  EXPECT_NEAR(one, static_cast<double>(exact), 1e-12 * std::exp(10.0) * 5000);
  EXPECT_EQ(chunked_sum(0, 2, term), 0.0);
}

TEST(Energies, EveryModelsEnergyHasTheSameBitsOnOneAndTwoThreads) {
  // A 48x48 sheet (4418 triangles, > kParallelMinVertices elements: the chunks run in parallel), deformed.
  std::mt19937 rng(8);
  for (const std::string& model : model_names()) {
    GridSpec g;
    g.nodes_u = g.nodes_v = 48;
    auto mesh = ClothMesh::grid(g);
    Cloth cloth("sheet", mesh, material_preset("cotton"));
    add_model_terms(cloth, model, "", "model");
    cloth.state().x = perturbed(mesh->rest_positions(), 0.005, rng);
    const double one = cloth.elastic_energy(1), two = cloth.elastic_energy(2);
    EXPECT_GT(one, 0.0) << model;
    EXPECT_EQ(one, two) << model;
  }
}

}  // namespace
}  // namespace loom::cloth
