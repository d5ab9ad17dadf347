// Integrators against exact solutions: free fall (error order), a mass on a spring (period, energy,
// the symplectic stability limit h = 2 sqrt(m/k) from both sides).
#include <gtest/gtest.h>

#include <cmath>

#include "TestUtil.h"
#include "loom/cloth/ExplicitSolvers.h"
#include "loom/cloth/GravityTerm.h"
#include "loom/cloth/SpringTerm.h"

namespace loom::cloth {
namespace {

constexpr double kPi = 3.14159265358979323846;

SolverSettings settings_for(const std::string& method) {
  SolverSettings s;
  s.method = method;
  return s;
}

// Vertex 0 is free with mass m; vertices 1 and 2 are fixed (inverse mass 0).
std::unique_ptr<Cloth> one_free_vertex(double m) {
  auto c = test::triangle_cloth();
  ClothState& s = c->state();
  s.mass = {m, 1.0, 1.0};
  s.inv_mass = {1.0 / m, 0.0, 0.0};
  return c;
}

double free_fall_error(const std::string& method, double h, double T) {
  auto c = one_free_vertex(1.0);
  const Vec3 g(0.0, -9.81, 0.0), x0(0.0, 0.0, 0.0), v0(1.0, 2.0, 0.5);
  c->add_term(std::make_unique<GravityTerm>(c->state().mass, g));
  c->state().x[0] = x0;
  c->state().v[0] = v0;
  auto solver = make_solver(settings_for(method));
  const int steps = static_cast<int>(std::lround(T / h));
  for (int k = 0; k < steps; ++k) solver->step(*c, k * h, h, 1);
  const Vec3 exact = x0 + v0 * T + 0.5 * g * T * T;
  return (c->state().x[0] - exact).norm();
}

TEST(FreeFall, EulerMethodsAreFirstOrderWithTheExactErrorConstant) {
  for (const char* method : {"explicit_euler", "symplectic_euler"}) {
    const double e1 = free_fall_error(method, 0.01, 1.0), e2 = free_fall_error(method, 0.005, 1.0);
    // Both err by exactly g T h / 2 for constant acceleration.
    EXPECT_NEAR(e1, 9.81 * 1.0 * 0.01 / 2, 1e-9) << method;
    EXPECT_NEAR(e1 / e2, 2.0, 1e-6) << method;
  }
}

TEST(FreeFall, VerletIsExactForConstantAcceleration) {
  EXPECT_LT(free_fall_error("verlet", 0.01, 1.0), 1e-12);
  EXPECT_LT(free_fall_error("verlet", 1.0 / 60.0, 2.0), 1e-12);
}

// A mass m on a spring k (rest length L) fixed at the origin, displaced by A along x.
struct Oscillator {
  std::unique_ptr<Cloth> cloth;
  std::unique_ptr<Solver> solver;
  double m, k, L = 1.0;
  Oscillator(const std::string& method, double m_, double k_, double A) : m(m_), k(k_) {
    cloth = test::triangle_cloth();
    ClothState& s = cloth->state();
    s.mass = {1.0, m, 1.0};
    s.inv_mass = {0.0, 1.0 / m, 0.0};
    s.x = {Vec3::Zero(), Vec3(L + A, 0, 0), Vec3(0, 5, 0)};
    s.v.assign(3, Vec3::Zero());
    cloth->add_term(std::make_unique<SpringTerm>(3, std::vector<Spring>{{0, 1, L, k, 0.0}}));
    solver = make_solver(settings_for(method));
  }
  double displacement() const { return cloth->state().x[1].x() - L; }
  double energy() const {
    const ClothState& s = cloth->state();
    const double stretch = (s.x[1] - s.x[0]).norm() - L;
    return 0.5 * m * s.v[1].squaredNorm() + 0.5 * k * stretch * stretch;
  }
  void step(double h, int k_step) { solver->step(*cloth, k_step * h, h, 1); }
};

TEST(Oscillator, PeriodMatchesTwoPiSqrtMOverK) {
  const double m = 0.5, k = 200.0, period = 2 * kPi * std::sqrt(m / k);
  for (const char* method : {"symplectic_euler", "verlet"}) {
    Oscillator o(method, m, k, 0.1);
    const double h = period / 2000.0;
    // Upward zero crossings of the displacement, linearly interpolated.
    std::vector<double> crossings;
    double prev = o.displacement();
    for (int s = 0; s < 2000 * 12 && crossings.size() < 11; ++s) {
      o.step(h, s);
      const double cur = o.displacement();
      if (prev < 0.0 && cur >= 0.0) crossings.push_back((s + prev / (prev - cur)) * h);
      prev = cur;
    }
    ASSERT_GE(crossings.size(), 11u) << method;
    const double measured = (crossings.back() - crossings.front()) / 10.0;
    EXPECT_NEAR(measured / period, 1.0, 0.005)
        << method << ": measured " << measured << " s, exact " << period;
  }
}

TEST(Oscillator, SymplecticEnergyStaysBoundedOverTenThousandSteps) {
  const double m = 0.5, k = 200.0, omega = std::sqrt(k / m);
  for (const char* method : {"symplectic_euler", "verlet"}) {
    Oscillator o(method, m, k, 0.1);
    const double h = 0.1 / omega, e0 = o.energy();
    double early = 0.0, late = 0.0;
    for (int s = 0; s < 10000; ++s) {
      o.step(h, s);
      const double dev = std::abs(o.energy() - e0) / e0;
      if (s < 1000) early = std::max(early, dev);
      if (s >= 9000) late = std::max(late, dev);
    }
    EXPECT_LT(early, 0.1) << method;                  // O(h ω) oscillation ...
    EXPECT_LT(late, 1.05 * early + 1e-12) << method;  // ... and no drift
  }
}

TEST(Oscillator, ExplicitEulerGainsEnergyOnAnUndampedSpring) {
  const double m = 0.5, k = 200.0, omega = std::sqrt(k / m);
  Oscillator o("explicit_euler", m, k, 0.1);
  const double e0 = o.energy();
  for (int s = 0; s < 1000; ++s) o.step(0.01 / omega, s);
  // |R| = sqrt(1 + h²ω²) per step: energy grows by (1 + 1e-4)^1000 ≈ 1.105.
  EXPECT_NEAR(o.energy() / e0, std::pow(1.0 + 1e-4, 1000), 0.01);
}

TEST(Oscillator, SymplecticStabilityLimitIsTwoSqrtMOverK) {
  const double m = 0.5, k = 200.0, A = 1e-3, limit = 2.0 * std::sqrt(m / k);
  for (const char* method : {"symplectic_euler", "verlet"}) {
    {
      Oscillator below(method, m, k, A);
      double peak = 0.0;
      for (int s = 0; s < 10000; ++s) {
        below.step(0.99 * limit, s);
        peak = std::max(peak, std::abs(below.displacement()));
      }
      // Bounded: the numerical orbit's amplitude is A / sqrt(1 - (hω/2)²) ≈ 7.1 A at hω = 1.98.
      EXPECT_LT(peak, 10.0 * A) << method << " just below the limit";
    }
    {
      Oscillator above(method, m, k, A);
      int blown = -1;
      for (int s = 0; s < 200 && blown < 0; ++s) {
        above.step(1.01 * limit, s);
        if (std::abs(above.displacement()) > 100.0 * A) blown = s;
      }
      EXPECT_GE(blown, 0) << method << " just above the limit must blow up";
    }
  }
}

}  // namespace
}  // namespace loom::cloth
