// AeroTerm: the flat-plate drag and lift of AeroTerm.h against hand-computed values, the third-per-vertex
// distribution, gusts and swing, the ranges the settings accept, and that a wind of zero density leaves a run
// bit for bit as it is without wind.
#include <gtest/gtest.h>

#include <cmath>

#include "TestUtil.h"
#include "loom/cloth/AeroTerm.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

constexpr double kPi = 3.141592653589793;

WindSettings plate_wind() {
  WindSettings s;
  s.velocity = Vec3(10.0, 0.0, 0.0);
  s.density = 1.2;
  s.drag = 1.1;
  s.lift = 0.7;
  return s;
}

// A right triangle of area ½ spanning the chord d = (cos α, sin α, 0) and the span z: the flow along +x meets
// it at the angle of attack α. ½ ρ A |u|² = ½ · 1.2 · ½ · 100 = 30 N, so by hand
//   drag = 30 · 1.1 · sin α = 33 sin α,  lift = 30 · 0.7 · sin α cos α = 21 sin α cos α,
// the lift pointing -y (the flow strikes the face whose normal is (-sin α, cos α, 0) and pushes it away).
struct PlateCase {
  double alpha_deg;
  double drag;  // N
  double lift;  // N
};
const PlateCase kPlate[] = {
    {0.0, 0.0, 0.0},
    {15.0, 8.541028488383182, 5.25},                // 33 (√6 - √2) / 4; 21 / 4 (sin 30°)
    {30.0, 16.5, 9.093266739736606},                // 33 / 2; 21 √3 / 4
    {45.0, 23.33452377915607, 10.5},                // 33 √2 / 2; 21 / 2
    {60.0, 28.578838324886473, 9.093266739736606},  // 33 √3 / 2; 21 √3 / 4
    {75.0, 31.875552267539252, 5.25},               // 33 (√6 + √2) / 4; 21 / 4
    {90.0, 33.0, 0.0},                              // face-on: all drag
};

TEST(Aero, FlatPlateDragAndLiftMatchTheFormulaAtEveryAngle) {
  const WindSettings s = plate_wind();
  double max_drag = 0.0;
  for (const PlateCase& pc : kPlate) {
    const double a = pc.alpha_deg * kPi / 180.0;
    const Vec3 x0(0, 0, 0), x1(std::cos(a), std::sin(a), 0), x2(0, 0, 1);
    const Vec3 f = AeroTerm::triangle_force(s, x0, x1, x2, Vec3::Zero(), s.velocity);
    const Vec3 uh = Vec3::UnitX();
    const double drag = f.dot(uh);
    const Vec3 lift = f - drag * uh;
    EXPECT_NEAR(drag, pc.drag, 1e-12) << pc.alpha_deg;
    EXPECT_NEAR(lift.norm(), pc.lift, 1e-12) << pc.alpha_deg;
    EXPECT_NEAR(lift.y(), -pc.lift, 1e-12) << pc.alpha_deg;  // in the plane of u and n, on the -y side
    EXPECT_NEAR(f.z(), 0.0, 1e-12) << pc.alpha_deg;          // nothing along the span
    // Two-sided: the other winding (normal flipped) gives the same force.
    const Vec3 g = AeroTerm::triangle_force(s, x0, x2, x1, Vec3::Zero(), s.velocity);
    EXPECT_NEAR((f - g).norm(), 0.0, 1e-12) << pc.alpha_deg;
    max_drag = std::max(max_drag, drag);
  }
  EXPECT_NEAR(max_drag, 33.0, 1e-12);  // the largest drag is face-on
}

TEST(Aero, OnlyTheRelativeVelocityCounts) {
  const WindSettings s = plate_wind();
  const double a = 0.4;
  const Vec3 x0(0, 0, 0), x1(std::cos(a), std::sin(a), 0), x2(0, 0, 1);
  const Vec3 in_wind = AeroTerm::triangle_force(s, x0, x1, x2, Vec3::Zero(), s.velocity);
  // The plate moving at -10 m/s through still air feels the same flow.
  const Vec3 moving = AeroTerm::triangle_force(s, x0, x1, x2, Vec3(-10, 0, 0), Vec3::Zero());
  EXPECT_NEAR((in_wind - moving).norm(), 0.0, 1e-12);
  // Carried by the wind: no force.
  EXPECT_EQ(AeroTerm::triangle_force(s, x0, x1, x2, s.velocity, s.velocity), Vec3::Zero());
  // Quadratic in the speed.
  WindSettings s2 = s;
  s2.velocity *= 2.0;
  const Vec3 twice = AeroTerm::triangle_force(s2, x0, x1, x2, Vec3::Zero(), s2.velocity);
  EXPECT_NEAR((twice - 4.0 * in_wind).norm(), 0.0, 1e-12);
}

TEST(Aero, EachVertexGetsAThirdOfItsTrianglesForce) {
  const auto mesh = test::small_grid();
  WindSettings s = plate_wind();
  s.velocity = Vec3(3.0, -1.0, 6.0);
  AeroTerm term(s, mesh->triangles(), mesh->num_vertices());
  std::mt19937 rng(7);
  const Vec3s x = test::perturbed(mesh->rest_positions(), 0.05, rng);
  Vec3s v(x.size());
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (Vec3& vi : v) vi = Vec3(u(rng), u(rng), u(rng));
  const Vec3s f = test::term_forces(term, x, v);
  Vec3s expect(x.size(), Vec3::Zero());
  for (const Tri& t : mesh->triangles()) {
    const Vec3 ft = AeroTerm::triangle_force(s, x[t[0]], x[t[1]], x[t[2]],
                                             (v[t[0]] + v[t[1]] + v[t[2]]) / 3.0, s.velocity);
    for (int k : t) expect[k] += ft / 3.0;
  }
  for (size_t i = 0; i < x.size(); ++i) EXPECT_NEAR((f[i] - expect[i]).norm(), 0.0, 1e-12) << i;
  EXPECT_EQ(term.energy(EvalContext{x, v, 0.0, 1}), 0.0);
  EXPECT_FALSE(term.conservative());
}

TEST(Aero, GustsScaleAndTheSwingTurnsTheWind) {
  WindSettings s;
  s.velocity = Vec3(8.0, 0.0, 0.0);
  s.gusts = {Gust{0.25, 0.5, 0.0}, Gust{0.1, 2.0, kPi / 2}};
  s.swing_angle = kPi / 6;
  s.swing_frequency = 0.25;
  s.validate("", "effects.wind");
  // t = 1 s: gusts 0.25 sin(π) + 0.1 sin(4π + π/2) = 0.1; swing (π/6) sin(π/2) = 30° about +y.
  const Vec3 w = s.velocity_at(1.0);
  const double speed = 8.0 * 1.1;
  EXPECT_NEAR(w.x(), speed * std::cos(kPi / 6), 1e-12);
  EXPECT_NEAR(w.y(), 0.0, 1e-12);
  EXPECT_NEAR(w.z(), -speed * std::sin(kPi / 6), 1e-12);  // a positive turn about +y takes +x toward -z
  EXPECT_NEAR(s.max_speed(), 8.0 * 1.35, 1e-12);
  for (double t = 0.0; t < 10.0; t += 0.01) EXPECT_LE(s.velocity_at(t).norm(), s.max_speed() + 1e-12);
}

TEST(Aero, SettingsOutOfRangeNameTheField) {
  auto message = [](WindSettings s) {
    try {
      s.validate("scene.json", "effects.wind");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  WindSettings s;
  s.density = -1.0;
  EXPECT_NE(message(s).find("scene.json: effects.wind.density: must be in [0, 2000]"), std::string::npos);
  s = WindSettings{};
  s.velocity = Vec3(std::nan(""), 0, 0);
  EXPECT_NE(message(s).find("effects.wind.velocity: must be finite"), std::string::npos);
  s = WindSettings{};
  s.drag = 11.0;
  EXPECT_NE(message(s).find("effects.wind.drag: must be in [0, 10]"), std::string::npos);
  s = WindSettings{};
  s.lift = -0.1;
  EXPECT_NE(message(s).find("effects.wind.lift"), std::string::npos);
  s = WindSettings{};
  s.gusts = {Gust{0.2, 1.0, 0.0}, Gust{1.5, 1.0, 0.0}};
  EXPECT_NE(message(s).find("effects.wind.gusts[1].amplitude"), std::string::npos);
  s = WindSettings{};
  s.swing_axis = Vec3::Zero();
  EXPECT_NE(message(s).find("effects.wind.swing.axis"), std::string::npos);
  // An axis whose length underflows or overflows still has a direction: accepted, made unit.
  for (const Vec3& axis : {Vec3(1e-300, 0, 0), Vec3(1e300, 1e300, 0)}) {
    s = WindSettings{};
    s.swing_axis = axis;
    EXPECT_EQ(message(s), "") << axis.transpose();
    s.validate("scene.json", "effects.wind");
    const Vec3 direction = (axis / axis.cwiseAbs().maxCoeff()).normalized();
    EXPECT_NEAR((s.swing_axis - direction).norm(), 0.0, 1e-15);
  }
  EXPECT_EQ(message(WindSettings{}), "");
  // The Simulation checks them too (an API caller gets the same message).
  SimulationSetup setup = test::hanging_sheet(5);
  setup.wind = WindSettings{};
  setup.wind->density = -2.0;
  EXPECT_THROW(Simulation(setup, "api"), Error);
}

// Without `wind` there is no aero term; a wind of zero density gives exactly the same run (the forces it adds
// are +0), so adding the effect costs nothing where it does nothing.
TEST(Aero, NoWindNoTermAndZeroDensityIsBitIdentical) {
  SimulationSetup plain = test::hanging_sheet(9);
  plain.substeps = 20;
  Simulation a(plain);
  EXPECT_EQ(a.cloths()[0]->find_term("aero"), nullptr);
  for (const std::string& n : a.stage_names()) EXPECT_EQ(n.find("aero"), std::string::npos) << n;
  SimulationSetup still = plain;
  still.wind = WindSettings{};
  still.wind->velocity = Vec3(5, 0, 0);
  still.wind->density = 0.0;
  Simulation b(still);
  ASSERT_NE(b.cloths()[0]->find_term("aero"), nullptr);
  for (int f = 0; f < 20; ++f) {
    a.step_frame();
    b.step_frame();
  }
  const Vec3s& xa = a.cloths()[0]->state().x;
  const Vec3s& xb = b.cloths()[0]->state().x;
  for (size_t i = 0; i < xa.size(); ++i) EXPECT_EQ(xa[i], xb[i]) << i;
}

}  // namespace
}  // namespace loom::cloth
