#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "loom/cloth/DesbrunSolver.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/ExplicitSolvers.h"
#include "loom/cloth/FastXpbdSolver.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/ImplicitSolver.h"
#include "loom/cloth/PositionBasedSolvers.h"
#include "loom/cloth/ProjectiveSolver.h"
#include "loom/cloth/Solver.h"
#include "loom/cloth/StaticSolver.h"
#include "loom/cloth/WeilSolver.h"

namespace loom::cloth {

namespace {
// A bound or value as the user would write it (9 significant digits: 0.0001, 1e-09, 2).
std::string show(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%.9g", v);
  return s;
}
}  // namespace

double SolverParams::number(const std::string& key, double fallback, double min, double max) {
  read_.insert(key);
  auto it = s_.params.find(key);
  if (it == s_.params.end()) return fallback;
  const double v = it->second;
  if (!std::isfinite(v) || v < min || v > max)
    throw Error(file_, "solver." + key,
                "must be in [" + show(min) + ", " + show(max) + "] (got " + show(v) + ")");
  return v;
}

int SolverParams::integer(const std::string& key, int fallback, int min, int max) {
  const double v = number(key, fallback, min, max);
  if (v != std::floor(v)) throw Error(file_, "solver." + key, "expected an integer");
  return static_cast<int>(v);
}

bool SolverParams::flag(const std::string& key, bool fallback) {
  return number(key, fallback ? 1 : 0, 0, 1) != 0.0;
}

void SolverParams::finish() const {
  for (const auto& kv : s_.params)
    if (!read_.count(kv.first))
      throw Error(file_, "solver." + kv.first,
                  "unknown parameter for method '" + show_value(s_.method) + "'");
}

namespace {

std::unique_ptr<Solver> make_implicit_solver(ImplicitSolver::Scheme scheme, SolverParams& p) {
  ImplicitParams ip;
  ip.cg_tolerance = p.number("cg_tolerance", ip.cg_tolerance, 1e-14, 1.0);
  ip.cg_max_iterations = p.integer("cg_max_iterations", ip.cg_max_iterations, 1, 1000000);
  if (scheme != ImplicitSolver::Scheme::kImex)  // imex is linearised only
    ip.newton_iterations = p.integer("newton_iterations", ip.newton_iterations, 1, 1000);
  ip.adaptive = p.flag("adaptive", ip.adaptive);
  ip.max_strain_change = p.number("max_strain_change", ip.max_strain_change, 1e-9, 1e9);
  ip.safeguard = p.flag("safeguard", ip.safeguard);
  ip.safeguard_tolerance = p.number("safeguard_tolerance", ip.safeguard_tolerance, 0.0, 1e9);
  ip.safeguard_newton_iterations =
      p.integer("safeguard_newton_iterations", ip.safeguard_newton_iterations, 1, 1000);
  ip.clamp_compression = p.flag("clamp_compression", ip.clamp_compression);
  ip.multigrid = p.integer("multigrid", ip.multigrid, 0, 2);
  ip.contact_filter = p.flag("contact_filter", ip.contact_filter);
  return std::make_unique<ImplicitSolver>(scheme, ip);
}

struct Entry {
  const char* name;
  std::function<std::unique_ptr<Solver>(SolverParams&)> make;
};

// Every solver, by the name scenes use for it (`solver.method`).
const std::vector<Entry>& registry() {
  static const std::vector<Entry> entries = {
      {"explicit_euler", [](SolverParams&) { return std::make_unique<ExplicitEuler>(); }},
      {"symplectic_euler", [](SolverParams&) { return std::make_unique<SymplecticEuler>(); }},
      {"verlet", [](SolverParams&) { return std::make_unique<Verlet>(); }},
      // Baraff & Witkin 1998 backward Euler and Choi & Ko 2002 BDF2 (ImplicitSolver.h).
      {"implicit_euler",
       [](SolverParams& p) { return make_implicit_solver(ImplicitSolver::Scheme::kBackwardEuler, p); }},
      {"bdf2", [](SolverParams& p) { return make_implicit_solver(ImplicitSolver::Scheme::kBdf2, p); }},
      // Implicit-explicit split: stiff in-plane terms implicit, bending and the rest explicit
      // (ImplicitSolver.h).
      {"imex", [](SolverParams& p) { return make_implicit_solver(ImplicitSolver::Scheme::kImex, p); }},
      // Position-based and projective solvers on the springs (PositionBasedSolvers.h, ProjectiveSolver.h).
      {"pbd",
       [](SolverParams& p) {
         const int iterations = p.integer("iterations", 10, 1, 100000);
         return std::make_unique<PbdSolver>(iterations, p.number("stiffness", 1.0, 0.0, 1.0));
       }},
      {"xpbd",
       [](SolverParams& p) {
         const int iterations = p.integer("iterations", 10, 1, 100000);
         return std::make_unique<XpbdSolver>(iterations, p.number("compliance_scale", 1.0, 0.0, 1e12));
       }},
      // The real-time tier's XPBD: small steps, one iteration, structure-of-arrays data (FastXpbdSolver.h).
      {"fast_xpbd",
       [](SolverParams& p) {
         const int iterations = p.integer("iterations", 1, 1, 100000);
         return std::make_unique<FastXpbdSolver>(iterations, p.number("compliance_scale", 1.0, 0.0, 1e12));
       }},
      {"projective",
       [](SolverParams& p) {
         ProjectiveSettings s;
         s.iterations = p.integer("iterations", s.iterations, 1, 100000);
         s.chebyshev = p.flag("chebyshev", s.chebyshev);
         s.rho = p.number("rho", s.rho, 0.0, 0.9999);
         s.warmup = p.integer("warmup", s.warmup, 0, 100000);
         s.strain_limit = p.number("strain_limit", s.strain_limit, 0.0, 0.99);
         s.strain_stiffness = p.number("strain_stiffness", s.strain_stiffness, 0.0, 1e12);
         return std::make_unique<ProjectiveSolver>(s);
       }},
      // Static equilibrium by Newton energy minimisation (StaticSolver.h).
      {"static",
       [](SolverParams& p) {
         StaticSettings s;
         s.max_iterations = p.integer("iterations", s.max_iterations, 1, 100000);
         s.tolerance = p.number("tolerance", s.tolerance, 0.0, 1.0);
         return std::make_unique<StaticSolver>(s);
       }},
      // Weil 1986 geometric drape from catenaries, static scenes only (WeilSolver.h).
      {"weil", [](SolverParams&) { return std::make_unique<WeilSolver>(); }},
      {"desbrun",
       [](SolverParams& p) { return std::make_unique<DesbrunSolver>(p.flag("angular_correction", true)); }},
  };
  return entries;
}

}  // namespace

std::unique_ptr<Solver> make_solver(const SolverSettings& settings, const std::string& file) {
  for (const Entry& e : registry())
    if (settings.method == e.name) {
      SolverParams params(settings, file);
      auto solver = e.make(params);
      params.finish();
      return solver;
    }
  std::string known;
  for (const auto& n : solver_names()) known += (known.empty() ? "" : ", ") + n;
  throw Error(file, "solver.method",
              "unknown method '" + show_value(settings.method) + "' (known: " + known + ")");
}

int default_substeps(const std::string& method, double frame_dt) {
  if (method != "fast_xpbd" || !(frame_dt > 0.0) || !std::isfinite(frame_dt)) return 1;
  constexpr double kFastXpbdStep = 1.0 / 720.0;  // s
  return static_cast<int>(std::clamp(std::ceil(frame_dt / kFastXpbdStep - 1e-9), 1.0, 1e6));
}

bool takes_springs_only(const std::string& method) {
  return method == "pbd" || method == "xpbd" || method == "fast_xpbd" || method == "projective" ||
         method == "desbrun";
}

std::vector<std::string> solver_names() {
  std::vector<std::string> names;
  for (const Entry& e : registry()) names.push_back(e.name);
  return names;
}

}  // namespace loom::cloth
