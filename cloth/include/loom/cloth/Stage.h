#pragma once
// Stage: one step of the pipeline (docs/architecture.md, "One step"). The pipeline is built from the scene
// once and holds only the stages the scene needs; each stage reports its time and work counters.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "loom/cloth/Cloth.h"
#include "loom/cloth/StateArchive.h"

namespace loom::cloth {

struct StageContext {
  std::vector<std::unique_ptr<Cloth>>& cloths;
  double t = 0.0;  // s, time at the start of the step
  double h = 0.0;  // s, step size
  int threads = 1;
};

class Stage {
 public:
  virtual ~Stage() = default;
  virtual const char* name() const = 0;
  virtual void run(StageContext& ctx) = 0;
  // Work counters since the start (name, value), e.g. ("pinned_vertices", 2).
  virtual std::vector<std::pair<std::string, double>> counters() const { return {}; }
  // State kept across steps (contact caches, collider poses, rig state), saved at each frame start by the
  // non-finite guard (restored when a frame is rolled back and retried with smaller steps) and written into
  // checkpoints (`loom run --checkpoint-every`). Stateless stages keep the defaults.
  virtual void save_state(StateWriter& out) const { (void)out; }
  virtual void load_state(StateReader& in) { (void)in; }
  // Guard (Guard.h): "" or why the step this stage has just run left a state the run must not keep (e.g.
  // contacts it could not resolve). The guard checks it after every step: the frame is rolled back and run
  // again with smaller steps, and if that fails too the run stops with this cause.
  virtual std::string violation() const { return {}; }
  // Guard's energy budget (GuardSettings::energy_bound): the energy (J) this stage has put into the cloths
  // from outside since the start (e.g. a moving collider's push), an upper estimate. Part of the saved state.
  virtual double work_in() const { return 0.0; }
};

}  // namespace loom::cloth
