#include "loom/eval/AccuracySweep.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace loom::eval {

std::string SweepConfig::label() const {
  std::ostringstream s;
  s << "substeps=" << substeps;
  for (const auto& kv : params) s << ' ' << kv.first << '=' << kv.second;
  if (!model.empty()) s << " model=" << model;
  return s.str();
}

namespace {

std::vector<SweepConfig> grid(const std::vector<int>& substeps, const std::string& key,
                              const std::vector<double>& values,
                              const std::map<std::string, double>& extra = {},
                              const std::string& model = "") {
  std::vector<SweepConfig> out;
  for (int s : substeps)
    for (double v : values) {
      SweepConfig c;
      c.substeps = s;
      c.params = extra;
      c.model = model;
      if (!key.empty()) c.params[key] = v;
      out.push_back(c);
    }
  return out;
}

void append(std::vector<SweepConfig>& a, const std::vector<SweepConfig>& b) {
  a.insert(a.end(), b.begin(), b.end());
}

}  // namespace

std::map<std::string, std::vector<SweepConfig>> loom_sweep_table(int explicit_steps, bool quick) {
  const int e = std::max(1, explicit_steps);
  auto times = [&](double f) { return std::max(1, static_cast<int>(std::lround(e * f))); };
  std::map<std::string, std::vector<SweepConfig>> t;
  // Explicit schemes (docs/references.md, "Time integration"): around the stability bound; explicit
  // Euler is unstable for undamped springs at any step, so it is swept only at and below the bound.
  t["explicit_euler"] = grid({times(1), times(2), times(4)}, "", {0});
  t["symplectic_euler"] = grid({times(0.5), times(1), times(2), times(4)}, "", {0});
  t["verlet"] = grid({times(0.5), times(1)}, "", {0});
  // Implicit schemes (Baraff-Witkin backward Euler, BDF2): step size x CG tolerance; Newton for accuracy.
  t["implicit_euler"] = grid({1, 2, 4, 8, 16}, "cg_tolerance", {1e-2, 1e-4, 1e-6});
  append(t["implicit_euler"], grid({1, 4}, "newton_iterations", {3}, {{"cg_tolerance", 1e-6}}));
  append(t["implicit_euler"], grid({1, 4}, "adaptive", {1}, {{"cg_tolerance", 1e-4}}));
  // The aggregation multigrid preconditioner (AggregationMultigrid.h): 1 = additive finest level, 2 =
  // V-cycle; one substep at the loosest tolerances that keep the max strain (docs/benchmarks.md).
  append(t["implicit_euler"], grid({1}, "cg_tolerance", {1e-2, 2e-2}, {{"multigrid", 1}}));
  append(t["implicit_euler"], grid({1}, "cg_tolerance", {1e-2, 3e-2}, {{"multigrid", 2}}));
  // The same at 0.02 with the CG capped at 10 or 12 iterations (a step needs 13.4 on average): the fastest
  // within a point of the reference max strain at N=64 (docs/benchmarks.md).
  append(t["implicit_euler"],
         grid({1}, "cg_max_iterations", {10, 12}, {{"multigrid", 1}, {"cg_tolerance", 2e-2}}));
  t["bdf2"] = grid({1, 2, 4, 8, 16}, "cg_tolerance", {1e-3, 1e-6});
  // IMEX: structural and shear springs implicit, bend springs and gravity explicit (ImplicitSolver.h).
  t["imex"] = grid({1, 2, 4, 8, 16}, "cg_tolerance", {1e-4});
  // The co-rotated FEM membrane (+ dihedral bending) model under backward Euler and IMEX: a different model
  // of the same material, so its error against the springs reference includes the model difference.
  append(t["implicit_euler"], grid({1, 4, 16}, "cg_tolerance", {1e-4}, {}, "corotated_fem"));
  append(t["imex"], grid({1, 4, 16}, "cg_tolerance", {1e-4}, {}, "corotated_fem"));
  t["desbrun"] = grid({1, 2, 4, 8, 16}, "", {0});
  // Constraint-based (PBD, XPBD, projective dynamics): step size x iterations, and the
  // substeps-of-one-iteration mode.
  for (const char* m : {"pbd", "xpbd"}) {
    t[m] = grid({1, 4, 16}, "iterations", {1, 4, 16});
    append(t[m], grid({64}, "iterations", {1}));
  }
  // XPBD "small steps" (Macklin et al. 2019: many substeps of one iteration), the games' 2 ms-class setting,
  // between 16 and 64 substeps; and projective dynamics at one substep with few Chebyshev iterations.
  append(t["xpbd"], grid({8, 32}, "iterations", {1}));
  // The real-time tier's XPBD (FastXpbdSolver.h): one iteration per substep, from the 2 ms class (at most 20
  // substeps at N=64) to many substeps, where it nears the dynamics the reference integrates.
  t["fast_xpbd"] = grid({8, 12, 16, 20, 24, 32, 64, 128, 256}, "iterations", {1});
  // With the tier's long-range attachments to the pins (AccuracyRuns.cpp, loom_setup).
  append(t["fast_xpbd"], grid({8, 12, 16, 20}, "tether_slack", {0.08}, {{"iterations", 1}}));
  // With the outward strain limit (StrainLimitStage.h, limit_stretch_outward; AccuracyRuns.cpp, loom_setup)
  // at 8 %, one sweep per substep: within a point of the reference max strain at 16 substeps
  // (docs/benchmarks.md).
  append(t["fast_xpbd"], grid({12, 16}, "strain_limit", {0.08},
                              {{"iterations", 1}, {"strain_limit_outward", 1}, {"strain_limit_sweeps", 1}}));
  t["projective"] = grid({1, 4, 16}, "iterations", {4, 16});
  append(t["projective"], grid({1}, "iterations", {4, 8}, {{"chebyshev", 1}}));
  append(t["projective"], grid({1, 4}, "iterations", {16}, {{"chebyshev", 1}}));
  // Quasi-static Newton minimisation per frame: not a dynamics integrator; its error is what ignoring
  // inertia costs.
  // 5 Newton iterations per frame: its default (100) took 9.6 s per frame at N=32.
  t["static"] = grid({1}, "iterations", {5});
  if (quick)
    for (auto& kv : t) {
      // The first configuration of each method, at a step the explicit schemes survive.
      SweepConfig c = kv.second.front();
      if (kv.first == "explicit_euler" || kv.first == "symplectic_euler") c.substeps = times(2);
      if (kv.first == "verlet") c.substeps = times(1);
      kv.second = {c};
    }
  return t;
}

bool static_only(const std::string& method) { return method == "weil"; }

std::map<std::string, std::vector<SweepConfig>> bullet_sweep_table(bool quick) {
  std::map<std::string, std::vector<SweepConfig>> t;
  // Classic btSoftBody: piterations x substeps (docs/bullet.md: works from piterations 10 at 1/240 s).
  t["bullet_classic"] = grid({1, 4}, "iterations", {4, 10, 20});
  // Deformable world: implicit + projection; substeps x Newton iterations (docs/bullet.md: 1/240 s needed).
  t["bullet_deformable"] = grid({1, 4, 8}, "iterations", {1});
  append(t["bullet_deformable"], grid({4}, "iterations", {3}));
  if (quick) {
    t["bullet_classic"] = grid({4}, "iterations", {10});
    t["bullet_deformable"] = grid({4}, "iterations", {1});
  }
  return t;
}

}  // namespace loom::eval
