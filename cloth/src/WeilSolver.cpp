#include "loom/cloth/WeilSolver.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "loom/cloth/Error.h"
#include "loom/cloth/GravityTerm.h"

namespace loom::cloth {

Vec3 catenary_point(const Vec3& a, const Vec3& b, double S, double s, const Vec3& down) {
  const Vec3 up = -down;
  const Vec3 ab = b - a;
  const double chord = ab.norm();
  if (!(S > 0.0)) return a;
  s = std::min(std::max(s, 0.0), S);
  if (S <= chord * (1.0 + 1e-12)) return a + (s / S) * ab;  // taut: the straight segment
  const double h = ab.dot(up);
  const Vec3 horiz = ab - h * up;
  const double d = horiz.norm();
  if (d <= 1e-12 * S) {
    // One above the other: two vertical strands meeting at the lowest point, l1 + l2 = S, l1 - l2 = -h.
    const double l1 = 0.5 * (S - h);
    return s <= l1 ? Vec3(a + s * down) : Vec3(b + (S - s) * down);
  }
  const Vec3 e = horiz / d;
  // 2α sinh(d/2α) = L = sqrt(S² - h²): with z = d/2α, sinh(z)/z = r = L/d > 1.
  const double L = std::sqrt(S * S - h * h), r = L / d;
  auto g = [&](double z) { return std::log(std::sinh(z) / z) - std::log(r); };
  double lo = 0.0, hi = 1.0;
  while (g(hi) < 0.0) hi *= 2.0;
  double z = 0.5 * (lo + hi);
  for (int it = 0; it < 200; ++it) {
    const double gz = g(z);
    if (gz < 0.0)
      lo = z;
    else
      hi = z;
    const double dz = gz / (1.0 / std::tanh(z) - 1.0 / z);  // Newton step, g' = coth z - 1/z
    double zn = z - dz;
    if (!(zn > lo && zn < hi)) zn = 0.5 * (lo + hi);  // safeguard: bisection
    if (std::abs(zn - z) <= 1e-15 * z) {
      z = zn;
      break;
    }
    z = zn;
  }
  const double alpha = d / (2.0 * z);
  // Lowest point at x0 (possibly outside [0, d]); arc length from a: α (sinh((x - x0)/α) + sinh(x0/α)).
  const double x0 = 0.5 * d - alpha * std::asinh(h / L);
  const double x = x0 + alpha * std::asinh(s / alpha - std::sinh(x0 / alpha));
  const double y = alpha * (std::cosh((x - x0) / alpha) - std::cosh(x0 / alpha));
  return a + x * e + y * up;
}

void weil_drape(const Cloth& cloth, const std::vector<std::pair<int, Vec3>>& pins, const Vec3& down,
                Vec3s& x) {
  const ClothMesh& mesh = cloth.mesh();
  const Vec3s& X = mesh.rest_positions();
  const int n = mesh.num_vertices();
  x.resize(n);
  std::vector<char> placed(n, 0);
  for (const auto& p : pins) {
    x[p.first] = p.second;
    placed[p.first] = 1;
  }
  const double none = -std::numeric_limits<double>::infinity();
  std::vector<double> best(n, none);
  Vec3s cand(n);
  // A vertex on several catenaries takes the highest (header).
  auto offer = [&](int i, const Vec3& p) {
    if (placed[i]) return;
    const double height = -p.dot(down);
    if (height > best[i]) {
      best[i] = height;
      cand[i] = p;
    }
  };
  auto commit = [&]() {
    bool any = false;
    for (int i = 0; i < n; ++i)
      if (!placed[i] && best[i] > none) {
        x[i] = cand[i];
        placed[i] = 1;
        any = true;
      }
    std::fill(best.begin(), best.end(), none);
    return any;
  };
  auto hang = [&](int a, int b, int k) {
    const double S = (X[b] - X[a]).norm();
    offer(k, catenary_point(x[a], x[b], S, (X[k] - X[a]).norm(), down));
  };
  // 1. Catenaries between every pair of constraint points, through the vertices on their rest segment.
  for (size_t p = 0; p < pins.size(); ++p)
    for (size_t q = p + 1; q < pins.size(); ++q) {
      const int a = pins[p].first, b = pins[q].first;
      const double S = (X[b] - X[a]).norm();
      if (!(S > 0.0)) continue;
      const Vec3 dir = (X[b] - X[a]) / S;
      for (int i = 0; i < n; ++i) {
        if (placed[i]) continue;
        const Vec3 r = X[i] - X[a];
        const double t = r.dot(dir);
        if (t <= 0.0 || t >= S || (r - t * dir).norm() > 1e-9 * S) continue;
        hang(a, b, i);
      }
    }
  commit();
  // 2. Subdivision along new catenaries: grid rows and columns between consecutive placed vertices.
  if (mesh.is_grid()) {
    const int nu = mesh.grid_nodes_u(), nv = mesh.grid_nodes_v();
    auto scan = [&](int count, int lines, auto index) {
      for (int l = 0; l < lines; ++l) {
        int prev = -1;
        for (int k = 0; k < count; ++k) {
          if (!placed[index(k, l)]) continue;
          if (prev >= 0 && k > prev + 1)
            for (int m = prev + 1; m < k; ++m) hang(index(prev, l), index(k, l), index(m, l));
          prev = k;
        }
      }
    };
    do {
      scan(nu, nv, [&](int k, int l) { return mesh.grid_index(k, l); });  // rows
      scan(nv, nu, [&](int k, int l) { return mesh.grid_index(l, k); });  // columns
    } while (commit());
  }
  // 3. The rest hangs straight down from the nearest placed vertex (rest distance), the higher one on a tie.
  std::vector<int> anchors;
  for (int i = 0; i < n; ++i)
    if (placed[i]) anchors.push_back(i);
  for (int i = 0; i < n; ++i) {
    if (placed[i]) continue;
    double nearest = std::numeric_limits<double>::infinity();
    for (int j : anchors) nearest = std::min(nearest, (X[i] - X[j]).norm());
    for (int j : anchors) {
      const double dist = (X[i] - X[j]).norm();
      if (dist <= nearest * (1.0 + 1e-12)) offer(i, x[j] + dist * down);
    }
  }
  commit();
}

void WeilSolver::check(const Cloth& cloth) const {
  if (cloth.pins().empty())
    throw Error("", "cloths[].pins",
                "the weil drape hangs a cloth from its constraint points: give at least one pin");
  for (size_t k = 0; k < cloth.pins().size(); ++k)
    if (!cloth.pins()[k].times.empty())
      throw Error("", "cloths[].pins[" + std::to_string(k) + "].path",
                  "the weil drape is a static shape: moving pins need a dynamic solver");
  if (!cloth.mesh().is_grid())
    throw Error(
        "", "cloths[].mesh",
        "the weil drape subdivides along grid rows and columns: it needs a grid mesh (mesh.type \"grid\")");
  for (const auto& t : cloth.terms())
    if (std::string(t->name()) == "drag")
      throw Error("", "effects.drag", "the weil drape has no dynamics: drag and wind need a dynamic solver");
    else if (std::string(t->name()) == "aero")
      throw Error("", "effects.wind", "the weil drape has no dynamics: wind needs a dynamic solver");
    else if (std::string(t->name()) == "pressure")
      throw Error("", "cloths[].pressure", "the weil drape has no dynamics: pressure needs a dynamic solver");
  // The catenaries hang along -y under a weight the shape does not depend on: a gravity of another
  // direction (or none) has no drape.
  Vec3 g = Vec3::Zero();
  for (const auto& t : cloth.terms())
    if (const auto* gt = dynamic_cast<const GravityTerm*>(t.get())) g += gt->g();
  if (!(g.squaredNorm() > 0.0) || !(-g.y() >= (1.0 - 1e-12) * g.norm())) {
    std::ostringstream why;
    why << "the weil drape hangs the cloth straight down along -y: gravity must point along -y with a "
           "non-zero magnitude (got ["
        << g.x() << ", " << g.y() << ", " << g.z() << "] m/s^2; other directions need a dynamic solver)";
    throw Error("", "gravity", why.str());
  }
  // Two constraint points farther apart than the cloth between them (rest distance) would stretch it
  // straight, and two vertices at one point fold it onto itself: neither has a catenary drape.
  const Vec3s& X = cloth.mesh().rest_positions();
  const auto& pins = cloth.pins();
  for (size_t p = 0; p < pins.size(); ++p)
    for (size_t q = p + 1; q < pins.size(); ++q) {
      if (pins[p].vertex == pins[q].vertex) continue;
      const double rest = (X[pins[q].vertex] - X[pins[p].vertex]).norm();
      const double apart = (pins[q].anchor - pins[p].anchor).norm();
      std::ostringstream why;
      if (!(apart > 1e-9 * rest))
        why << "its anchor coincides with pins[" << p << "]'s (vertices " << pins[p].vertex << " and "
            << pins[q].vertex << ", " << rest << " m apart at rest): the weil drape has no shape for it";
      else if (apart > rest * (1.0 + 1e-9))
        why << "its anchor lies " << apart << " m from pins[" << p << "]'s, farther than the cloth between "
            << "them (rest distance " << rest << " m): the weil drape cannot stretch the cloth";
      if (!why.str().empty()) throw Error("", "cloths[].pins[" + std::to_string(q) + "].anchor", why.str());
    }
  const ClothState& s = cloth.state();
  for (int i = 0; i < s.size(); ++i)
    if (s.inv_mass[i] != 0.0 && s.v[i].squaredNorm() > 0.0)
      throw Error("", "cloths[].velocity",
                  "the weil drape has no dynamics: an initial velocity needs a dynamic solver");
}

void WeilSolver::step(Cloth& cloth, double t, double h, int threads) {
  (void)t, (void)threads;
  ClothState& s = cloth.state();
  s.x_prev = s.x;
  for (int i = 0; i < s.size(); ++i)
    if (s.inv_mass[i] == 0.0) s.x[i] += h * s.v[i];  // pins at their targets (Solver.h contract)
  if (placed_ != &cloth) {
    const auto t0 = std::chrono::steady_clock::now();
    Vec3 down(0.0, -1.0, 0.0);
    for (const auto& term : cloth.terms())
      if (const auto* g = dynamic_cast<const GravityTerm*>(term.get()))
        if (g->g().squaredNorm() > 0.0) down = g->g().normalized();
    std::vector<std::pair<int, Vec3>> pins;
    for (int i = 0; i < s.size(); ++i)
      if (s.inv_mass[i] == 0.0) pins.emplace_back(i, s.x[i]);
    weil_drape(cloth, pins, down, s.x);
    placed_ = &cloth;
    last_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  for (Vec3& v : s.v) v.setZero();
}

}  // namespace loom::cloth
