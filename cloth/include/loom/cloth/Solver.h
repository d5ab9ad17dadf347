#pragma once
// Solver: one time integrator behind one interface (docs/architecture.md). Every solver consumes the cloth's
// terms only through Term; a solver that cannot use a term says so in check(), at set-up time.
// Contract for kinematic vertices (inverse mass 0): their velocity was set by the pin stage to reach the
// target at t + h, and the solver moves them by x += h v, whatever its scheme.
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "loom/cloth/Cloth.h"
#include "loom/cloth/StateArchive.h"

namespace loom::cloth {

struct SolverSettings {
  // One of solver_names(). The default is the real-time tier's solver (FastXpbdSolver.h: XPBD in small steps,
  // one iteration each), what a game would pick; it takes the springs model only (ClothSetup::model).
  std::string method = "fast_xpbd";
  // Solver-specific knobs by name (iterations, tolerance, ...): every key of the scene's `solver` object
  // other than method/substeps/dt. Each solver reads its own through SolverParams; others are errors.
  std::map<std::string, double> params;
  // True when the solver holds body contacts in its linear solve (`contact_filter` on, implicit solvers):
  // only then does a body-collision stage leave ClothState::contact_normal for it.
  bool holds_contacts() const {
    const auto it = params.find("contact_filter");
    return it != params.end() && it->second != 0.0;
  }
};

// Typed access to SolverSettings::params for one solver; finish() rejects keys the solver did not read,
// naming `solver.<key>`.
class SolverParams {
 public:
  SolverParams(const SolverSettings& s, std::string file) : s_(s), file_(std::move(file)) {}
  double number(const std::string& key, double fallback, double min, double max);
  int integer(const std::string& key, int fallback, int min, int max);
  bool flag(const std::string& key, bool fallback);
  void finish() const;

 private:
  const SolverSettings& s_;
  std::string file_;
  std::set<std::string> read_;
};

class Solver {
 public:
  virtual ~Solver() = default;
  virtual const char* name() const = 0;
  // Throws loom::Error if the cloth has a term this solver cannot use.
  virtual void check(const Cloth& cloth) const { (void)cloth; }
  // Advances the cloth from t to t + h.
  virtual void step(Cloth& cloth, double t, double h, int threads) = 0;
  // Forget any history (multistep state); called when the step size or the state changes from outside.
  virtual void reset() {}
  // A rigid frame (world from local, m) that moves with the cloth, e.g. a character's, for the next steps.
  // Solvers that round positions to float express them in it, so their rounding, and with it the motion,
  // does not depend on where the frame stands or which way it faces; the frame should lie within a few
  // metres of the cloth. Solvers in double ignore it (FastXpbdSolver.h).
  virtual void set_frame(const Eigen::Isometry3d& frame) { (void)frame; }
  // History kept between steps (multistep state, step sizes, warm starts), saved at each frame start by the
  // non-finite guard and in checkpoints, so a restored solver continues bit-identically. Solvers
  // whose step depends only on the cloth state keep the defaults.
  virtual void save_state(StateWriter& out) const { (void)out; }
  virtual void load_state(StateReader& in, const Cloth& cloth) { (void)in, (void)cloth; }
  // Work counters since construction (name, value), e.g. ("cg_iterations", 1234); shown in the profile.
  virtual std::vector<std::pair<std::string, double>> counters() const { return {}; }
};

// Throws loom::Error(file, "solver.method", ...) for an unknown method and (file, "solver.<key>", ...) for
// a parameter the method does not take or a value out of its range. Registry: SolverFactory.cpp.
std::unique_ptr<Solver> make_solver(const SolverSettings& settings, const std::string& file = "");
std::vector<std::string> solver_names();
// Whether `method` takes the springs model only (its check() refuses other models' terms): pbd, xpbd,
// fast_xpbd, projective and desbrun. Scenes refuse another model with it by the cloth's `model`.
bool takes_springs_only(const std::string& method);
// Steps per frame of `frame_dt` (s) for SimulationSetup::substeps = 0 ("the solver's default"): fast_xpbd
// takes steps of at most 1/720 s (12 per 60 Hz frame, the real-time tier's), every other method one step.
int default_substeps(const std::string& method, double frame_dt);

}  // namespace loom::cloth
