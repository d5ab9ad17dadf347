#pragma once
// Simulation: cloths plus a pipeline of stages built once from the setup:
//   pins (only with pins) -> solve (terms) -> [constraint passes, collision: later issues] -> stats
// Only the effects the setup names exist: no drag term without drag, no pin stage without pins.
#include <chrono>
#include <csignal>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "loom/cloth/AeroTerm.h"
#include "loom/cloth/AirDragTerm.h"
#include "loom/cloth/Cloth.h"
#include "loom/cloth/Guard.h"
#include "loom/cloth/PressureTerm.h"
#include "loom/cloth/Solver.h"
#include "loom/cloth/Stage.h"
#include "loom/cloth/StrainLimitStage.h"
#include "loom/cloth/TetherStage.h"

namespace loom::cloth {

struct PinSpec {
  int vertex = 0;
  std::optional<Vec3> anchor;  // m; default: the vertex's start position
  std::vector<double> times;   // s
  std::vector<Vec3> offsets;   // m
};

struct ClothSetup {
  std::string name = "cloth";
  std::shared_ptr<const ClothMesh> mesh;
  Material material;
  std::string model = "springs";  // one of model_names() (Model.h)
  std::vector<PinSpec> pins;
  std::vector<std::string> pin_fields;       // where pins[k] was given (a scene's JSON path), for messages
  Vec3 initial_velocity = Vec3::Zero();      // m/s
  std::optional<PressureSettings> pressure;  // gas pressure inside a closed mesh; absent = no pressure term
};

struct SimulationSetup {
  std::vector<ClothSetup> cloths;
  Vec3 gravity{0.0, -9.81, 0.0};     // m/s²
  std::optional<DragSettings> drag;  // the drag effect; absent = no drag term at all
  std::optional<WindSettings> wind;  // drag and lift of a wind on every cloth; absent = no aero term at all
  // Constraint passes after the solver, in this order; absent = no stage (StrainLimitStage.h, TetherStage.h).
  std::optional<StrainLimitSettings> strain_limit;
  std::optional<TetherSettings> tethers;
  SolverSettings solver;         // default: fast_xpbd, the real-time tier's solver (Solver.h)
  double frame_dt = 1.0 / 60.0;  // s
  int substeps = 0;  // solver steps per frame; 0: the solver's default (default_substeps, Solver.h)
  int threads = 1;
  GuardSettings guard;  // non-finite / explosion guard: roll back and retry with smaller steps (Guard.h)
};

// Per-frame measurements (stats.csv).
struct FrameStats {
  int frame = 0;
  double time = 0.0;         // s
  double kinetic = 0.0;      // J
  double potential = 0.0;    // J, gravitational, zero at y = 0 (along -g)
  double elastic = 0.0;      // J
  double max_strain = 0.0;   // 1, largest stretch l/L - 1 over strain edges (0 if none stretched)
  double mean_strain = 0.0;  // 1, mean stretch max(0, l/L - 1) over strain edges (<= max_strain)
  bool finite = true;
  std::vector<double> stage_ms;  // per row of stage_names(), this frame
  double total_ms = 0.0;         // the frame's pipeline time: top-level stages only (no "solve/<term>" rows)
};

struct StageProfile {
  std::string name;
  double total_ms = 0.0;
  std::vector<std::pair<std::string, double>> counters;
};

class Simulation {
 public:
  explicit Simulation(SimulationSetup setup, const std::string& file = "");

  // Where a stage added from outside goes (docs/architecture.md, "One step"):
  //   before_solve: after pins, before the solver (attachments to bones/bodies set their targets' velocities,
  //                 colliders read their poses for t and t+h);
  //   after_solve:  after the constraint passes, in the order added (collision stages), before "stats".
  enum class Slot { before_solve, after_solve };
  void add_stage(std::unique_ptr<Stage> stage, Slot slot = Slot::after_solve);

  // Runs `substeps` pipeline steps and returns the frame's statistics.
  FrameStats step_frame();
  // A stop request (a SIGINT handler's flag, nullptr: none), read between stages and between the guard's
  // retries: once it is non-zero the frame in progress is abandoned and the state restored to the frame's
  // start (interrupted() is then true until the next step_frame()).
  void set_stop_flag(const volatile std::sig_atomic_t* flag) { stop_flag_ = flag; }
  bool interrupted() const { return interrupted_; }
  // True once the stop flag is set (a frame stepped now would be abandoned at once).
  bool stop_requested() const { return stop_flag_ && *stop_flag_; }
  // Statistics of the current state (no stepping); used for frame 0.
  FrameStats measure() const;

  double time() const { return t_; }
  int frame() const { return frame_; }
  double step_size() const { return setup_.frame_dt / setup_.substeps; }
  // Changes the step mid-run (solvers adapt to a new h themselves: Verlet, BDF2, cached factorisations).
  void set_substeps(int substeps);
  // Sets the clock (time = frame * frame_dt), state untouched: a simulation rebuilt with other settings
  // (loom-view's effect toggles, material sliders) continues where the old one stopped.
  void set_frame(int frame) {
    frame_ = frame;
    t_ = frame * setup_.frame_dt;
  }

  // A host that steps this simulation in substeps of its own output frames (a Bullet world steps it once per
  // Bullet substep) names the output frame in progress and its length (s) here; failure() then names that
  // frame and its time span instead of this simulation's own. 0: failure() names this simulation's frame
  // (frame() + 1).
  void set_output_frame(int frame, double frame_dt) {
    output_frame_ = frame;
    output_frame_dt_ = frame_dt;
  }

  // The whole changing state: time, frame, every cloth's x, v, x_prev, every stage's and solver's
  // history. load_state restores it bit-identically (checkpoints; the guard's per-frame snapshot).
  void save_state(StateWriter& out) const;
  void load_state(StateReader& in);
  // Guard (Guard.h): the cause of the last failed frame ("" if none) and the frames rolled back so far.
  const std::string& failure() const { return failure_; }
  long rollbacks() const { return rollbacks_; }
  const SimulationSetup& setup() const { return setup_; }
  std::vector<std::unique_ptr<Cloth>>& cloths() { return cloths_; }
  const std::vector<std::unique_ptr<Cloth>>& cloths() const { return cloths_; }

  // Names of the timed rows: each stage, then "solve/<term>" rows for every term present, then "stats".
  std::vector<std::string> stage_names() const;
  std::vector<StageProfile> profile() const;

 private:
  void fill_stats(FrameStats& s) const;
  // n pipeline steps of frame_dt / n from frame_ (time by counting steps). With `stop_on_violation`, the
  // first step after which a stage reports Stage::violation() ends the loop early and its cause is returned.
  std::string run_substeps(int n, bool stop_on_violation = false);
  // Guard's energy budget (Guard.h, energy_bound): "" or why the frame just run breaks it; *pin_work (J)
  // receives the kinematic vertices' work of this frame.
  std::string energy_budget_violation(const FrameStats& end, double* pin_work);

  SimulationSetup setup_;
  std::vector<std::unique_ptr<Cloth>> cloths_;
  std::vector<std::unique_ptr<Stage>> stages_;
  std::vector<double> stage_total_ms_;
  double stats_total_ms_ = 0.0;
  std::vector<double> last_term_ms_;  // term totals at the previous frame, to report per-frame deltas
  double t_ = 0.0;
  int frame_ = 0;
  int output_frame_ = 0;          // set_output_frame; 0: none
  double output_frame_dt_ = 0.0;  // s, the output frame's length (set_output_frame)
  // Guard (SimulationState.cpp): frame-start snapshot, the frame-start sample, counters.
  StateWriter snapshot_;
  std::optional<GuardSample> start_sample_;
  double energy_scale_ = 0.0;  // J, E_ref of Guard.h
  // Energy budget (Guard.h, energy_bound), saved with the state: max(E_kin(0) + E_el(0), Σ m|g|L) (J; < 0
  // before the first frame), E_pot(0) (J) and the kinematic vertices' work so far (J).
  double budget_ref_ = -1.0, budget_potential0_ = 0.0, pin_work_ = 0.0;
  std::string failure_;
  // For a strain stop at time t: the moving pin that has moved farthest from its start by then (a path
  // that stretches the cloth past the guard's bound), named by its field; empty without moving pins.
  std::string moving_pin_note(double t) const;
  long rollbacks_ = 0, retried_frames_ = 0, failed_frames_ = 0;
  double guard_ms_ = 0.0;
  const volatile std::sig_atomic_t* stop_flag_ = nullptr;
  bool interrupted_ = false;
};

}  // namespace loom::cloth
