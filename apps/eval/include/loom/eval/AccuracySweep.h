#pragma once
// The knob sweeps of `loom bench accuracy`, keyed by solver or Bullet system name. A method that is not
// registered (loom::cloth::solver_names()) is skipped by the harness; a table entry whose parameters a
// solver rejects is skipped with a message, so solvers appear in the benchmark as soon as they land.
#include <map>
#include <string>
#include <vector>

namespace loom::eval {

// One configuration of one method: steps per 60 Hz frame plus the solver's own knobs (SolverSettings::params,
// or for the Bullet twins: "iterations").
struct SweepConfig {
  int substeps = 1;
  std::map<std::string, double> params;
  std::string model;          // the cloth's model (Model.h); empty: the scene's "springs" (FEM rows)
  std::string label() const;  // "substeps=4 iterations=10", the CSV's `config`
};

// `explicit_steps`: steps per frame at the conservative explicit stability bound of the mesh (Gershgorin,
// see AccuracyBench.cpp); explicit schemes are swept around it. `quick`: one configuration per method.
std::map<std::string, std::vector<SweepConfig>> loom_sweep_table(int explicit_steps, bool quick);
// Solvers for static scenes only (weil), which the dynamic hanging-cloth sweep skips.
bool static_only(const std::string& method);
// Keys "bullet_classic" and "bullet_deformable".
std::map<std::string, std::vector<SweepConfig>> bullet_sweep_table(bool quick);

}  // namespace loom::eval
