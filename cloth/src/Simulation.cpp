#include "loom/cloth/Simulation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "GuardInternal.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/GravityTerm.h"
#include "loom/cloth/ImplicitSolver.h"
#include "loom/cloth/Model.h"

namespace loom::cloth {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Sets each pinned vertex's velocity so that x + h v reaches its target at t + h (Solver.h contract).
class PinStage final : public Stage {
 public:
  const char* name() const override { return "pins"; }
  void run(StageContext& ctx) override {
    long count = 0;
    for (auto& cloth : ctx.cloths) {
      ClothState& s = cloth->state();
      for (const Pin& p : cloth->pins()) {
        s.v[p.vertex] = (p.target(ctx.t + ctx.h) - s.x[p.vertex]) / ctx.h;
        ++count;
      }
    }
    pinned_ += count;
  }
  std::vector<std::pair<std::string, double>> counters() const override {
    return {{"pin_updates", static_cast<double>(pinned_)}};
  }

 private:
  long pinned_ = 0;
};

// Advances every cloth with its own instance of the scene's solver.
class SolveStage final : public Stage {
 public:
  SolveStage(std::vector<std::unique_ptr<Solver>> solvers, const std::vector<std::unique_ptr<Cloth>>& cloths)
      : solvers_(std::move(solvers)) {
    for (const auto& c : cloths) cloths_.push_back(c.get());
  }
  const char* name() const override { return "solve"; }
  void run(StageContext& ctx) override {
    for (size_t k = 0; k < ctx.cloths.size(); ++k)
      solvers_[k]->step(*ctx.cloths[k], ctx.t, ctx.h, ctx.threads);
    ++steps_;
  }
  std::vector<std::pair<std::string, double>> counters() const override {
    std::vector<std::pair<std::string, double>> out = {{"steps", static_cast<double>(steps_)}};
    // The solvers' own counters (CG iterations, ...), summed over cloths by name.
    for (const auto& s : solvers_)
      for (const auto& counter : s->counters()) {
        const std::string& name =
            counter.first;  // no structured binding: C++17 lambdas cannot capture one (clang)
        const double value = counter.second;
        auto it = std::find_if(out.begin(), out.end(), [&](const auto& kv) { return kv.first == name; });
        if (it == out.end())
          out.emplace_back(name, value);
        else
          it->second += value;
      }
    return out;
  }
  // The first solver's violation (an implicit step that did not converge, ImplicitSolver::violation()),
  // naming its cloth.
  std::string violation() const override {
    for (size_t k = 0; k < solvers_.size(); ++k) {
      const auto* implicit = dynamic_cast<const ImplicitSolver*>(solvers_[k].get());
      const std::string why = implicit ? implicit->violation() : std::string();
      if (!why.empty()) return "cloth '" + cloths_[k]->name() + "': " + why;
    }
    return {};
  }
  // Each cloth's solver history (Solver.h).
  void save_state(StateWriter& out) const override {
    for (const auto& s : solvers_) s->save_state(out);
  }
  void load_state(StateReader& in) override {
    for (size_t k = 0; k < solvers_.size(); ++k) solvers_[k]->load_state(in, *cloths_[k]);
  }

 private:
  std::vector<std::unique_ptr<Solver>> solvers_;
  std::vector<const Cloth*> cloths_;  // solver k steps cloth k
  long steps_ = 0;
};

}  // namespace

Simulation::Simulation(SimulationSetup setup, const std::string& file) : setup_(std::move(setup)) {
  if (!(setup_.frame_dt > 0.0) || !std::isfinite(setup_.frame_dt))
    throw Error(file, "fps", "frame time step must be > 0");
  if (setup_.substeps < 0) throw Error(file, "solver.substeps", "must be >= 1 (or 0: the solver's default)");
  if (setup_.substeps == 0) setup_.substeps = default_substeps(setup_.solver.method, setup_.frame_dt);
  // A static equilibrium does not depend on the step (StaticSolver.h): one solve per frame, warm-started
  // from the last frame's. Only pins moving along a path make the substeps continuation steps of the solve.
  bool paths = false;
  for (const ClothSetup& c : setup_.cloths)
    for (const PinSpec& p : c.pins) paths = paths || !p.times.empty();
  if (setup_.solver.method == "static" && !paths) setup_.substeps = 1;
  if (setup_.threads < 1) throw Error(file, "threads", "must be >= 1");
  if (setup_.strain_limit &&
      !(setup_.strain_limit->max_stretch >= 0.0 && setup_.strain_limit->max_stretch < 1e6))
    throw Error(file, "constraints.strain_limit.max_stretch", "must be in [0, 1e6)");
  if (setup_.strain_limit && setup_.strain_limit->iterations < 1)
    throw Error(file, "constraints.strain_limit.iterations", "must be >= 1");
  if (setup_.tethers && !(setup_.tethers->slack >= 0.0 && setup_.tethers->slack < 1e6))
    throw Error(file, "constraints.tethers.slack", "must be in [0, 1e6)");
  if (!setup_.gravity.allFinite()) throw Error(file, "gravity", "must be finite");
  if (setup_.cloths.empty()) throw Error(file, "cloths", "a scene needs at least one cloth");
  if (setup_.wind) setup_.wind->validate(file, "effects.wind");
  std::vector<std::unique_ptr<Solver>> solvers;
  for (size_t c = 0; c < setup_.cloths.size(); ++c) {
    const ClothSetup& cs = setup_.cloths[c];
    const std::string where = "cloths[" + std::to_string(c) + "]";
    if (!cs.mesh) throw Error(file, where + ".mesh", "missing");
    cs.material.validate(file, where + ".material");
    auto cloth = std::make_unique<Cloth>(cs.name, cs.mesh, cs.material);
    // Only the effects the scene names become terms.
    if (setup_.gravity.squaredNorm() > 0.0)
      cloth->add_term(std::make_unique<GravityTerm>(cloth->state().mass, setup_.gravity));
    add_model_terms(*cloth, cs.model, file, where + ".model");
    if (setup_.drag)
      cloth->add_term(
          std::make_unique<AirDragTerm>(*setup_.drag, cs.mesh->triangles(), cs.mesh->vertex_areas()));
    if (setup_.wind)
      cloth->add_term(
          std::make_unique<AeroTerm>(*setup_.wind, cs.mesh->triangles(), cs.mesh->num_vertices()));
    if (cs.pressure) {
      cs.pressure->validate(file, where + ".pressure");
      const std::string open = closed_mesh_problem(static_cast<int>(cs.mesh->edges().size()),
                                                   static_cast<int>(cs.mesh->hinges().size()));
      if (!open.empty()) throw Error(file, where + ".pressure", open);
      auto term =
          std::make_unique<PressureTerm>(*cs.pressure, cs.mesh->triangles(), cs.mesh->rest_positions());
      if (!(term->rest_volume() > 0.0)) throw Error(file, where + ".pressure", "the mesh encloses no volume");
      cloth->add_term(std::move(term));
    }
    for (Vec3& v : cloth->state().v) v = cs.initial_velocity;
    for (size_t p = 0; p < cs.pins.size(); ++p) {
      const PinSpec& ps = cs.pins[p];
      const std::string pw = where + ".pins[" + std::to_string(p) + "]";
      if (ps.vertex < 0 || ps.vertex >= cs.mesh->num_vertices())
        throw Error(file, pw + ".vertex",
                    "vertex " + std::to_string(ps.vertex) + " is out of range [0, " +
                        std::to_string(cs.mesh->num_vertices()) + ")");
      if (ps.times.size() != ps.offsets.size()) throw Error(file, pw + ".path", "needs one offset per time");
      for (size_t k = 1; k < ps.times.size(); ++k)
        if (!(ps.times[k] > ps.times[k - 1])) throw Error(file, pw + ".path", "times must increase strictly");
      Pin pin;
      pin.vertex = ps.vertex;
      pin.anchor = ps.anchor.value_or(cloth->state().x[ps.vertex]);
      pin.times = ps.times;
      pin.offsets = ps.offsets;
      cloth->state().x[ps.vertex] = pin.target(0.0);
      cloth->state().v[ps.vertex] = Vec3::Zero();
      cloth->add_pin(std::move(pin));
    }
    cloth->state().x_prev = cloth->state().x;
    auto solver = make_solver(setup_.solver, file);
    try {
      solver->check(*cloth);
    } catch (const Error& e) {
      // The solver names the field ("cloths[].pins[1].anchor"), this cloth's index goes in, the file in
      // front.
      std::string why = e.what();
      if (why.rfind("cloths[]", 0) == 0) why.replace(0, 8, where);
      throw Error(file, "", why);
    }
    solvers.push_back(std::move(solver));
    cloths_.push_back(std::move(cloth));
  }
  bool any_pins = false;
  for (const auto& c : cloths_) any_pins = any_pins || !c->pins().empty();
  if (any_pins) stages_.push_back(std::make_unique<PinStage>());
  stages_.push_back(std::make_unique<SolveStage>(std::move(solvers), cloths_));
  if (setup_.strain_limit) stages_.push_back(std::make_unique<StrainLimitStage>(*setup_.strain_limit));
  if (setup_.tethers) stages_.push_back(std::make_unique<TetherStage>(*setup_.tethers));
  stage_total_ms_.assign(stages_.size(), 0.0);
  energy_scale_ = guard_energy_scale(setup_, cloths_);
}

void Simulation::add_stage(std::unique_ptr<Stage> stage, Slot slot) {
  size_t at = stages_.size();
  if (slot == Slot::before_solve) {
    at = 0;
    while (at < stages_.size() && std::string(stages_[at]->name()) != "solve") ++at;
  }
  stages_.insert(stages_.begin() + static_cast<std::ptrdiff_t>(at), std::move(stage));
  stage_total_ms_.insert(stage_total_ms_.begin() + static_cast<std::ptrdiff_t>(at), 0.0);
}

std::vector<std::string> Simulation::stage_names() const {
  std::vector<std::string> names;
  for (const auto& s : stages_) names.push_back(s->name());
  for (const auto& c : cloths_)
    for (const auto& t : c->terms()) {
      const std::string row = std::string("solve/") + t->name();
      if (std::find(names.begin(), names.end(), row) == names.end()) names.push_back(row);
    }
  names.push_back("stats");
  if (setup_.guard.enabled) names.push_back("guard");
  return names;
}

std::vector<StageProfile> Simulation::profile() const {
  std::vector<StageProfile> rows;
  for (size_t k = 0; k < stages_.size(); ++k)
    rows.push_back({stages_[k]->name(), stage_total_ms_[k], stages_[k]->counters()});
  for (const std::string& name : stage_names()) {
    if (name.rfind("solve/", 0) != 0) continue;
    StageProfile p{name, 0.0, {}};
    long calls = 0, items = 0;
    for (const auto& c : cloths_)
      for (size_t k = 0; k < c->terms().size(); ++k)
        if (name.compare(6, std::string::npos, c->terms()[k]->name()) == 0) {
          p.total_ms += c->term_timings()[k].ms;
          calls += c->term_timings()[k].calls;
          items += c->term_timings()[k].items;
        }
    p.counters = {{"evaluations", static_cast<double>(calls)}, {"elements", static_cast<double>(items)}};
    rows.push_back(p);
  }
  rows.push_back({"stats", stats_total_ms_, {}});
  if (setup_.guard.enabled)
    rows.push_back({"guard",
                    guard_ms_,
                    {{"rollbacks", double(rollbacks_)},
                     {"retried_frames", double(retried_frames_)},
                     {"failed_frames", double(failed_frames_)}}});
  return rows;
}

std::string Simulation::run_substeps(int n, bool stop_on_violation) {
  const double h = setup_.frame_dt / n;
  std::string why;
  for (int s = 0; s < n; ++s) {
    StageContext ctx{cloths_, t_, h, setup_.threads};
    // A stop request is read after each stage: the step is abandoned there (the caller restores the frame's
    // start), so a stop waits for one stage at most, not for the whole step.
    for (size_t k = 0; k < stages_.size() && !stop_requested(); ++k) {
      const auto start = Clock::now();
      stages_[k]->run(ctx);
      stage_total_ms_[k] += ms_since(start);
    }
    // Time advanced by counting steps, not by summing h, so it does not drift.
    t_ = (frame_ + static_cast<double>(s + 1) / n) * setup_.frame_dt;
    if (stop_requested()) {
      why = "stopped on request";
      break;
    }
    if (stop_on_violation) {
      for (const auto& stage : stages_) {
        why = stage->violation();
        if (!why.empty()) break;
      }
      if (!why.empty()) {
        why += " after step " + std::to_string(s + 1) + " of " + std::to_string(n);
        break;
      }
    }
  }
  ++frame_;
  t_ = frame_ * setup_.frame_dt;
  return why;
}

FrameStats Simulation::step_frame() {
  const std::vector<StageProfile> before = profile();
  FrameStats stats;
  interrupted_ = false;
  if (!setup_.guard.enabled) {
    if (stop_flag_) {  // a stop mid-frame goes back to the frame start
      snapshot_.clear();
      save_state(snapshot_);
    }
    run_substeps(setup_.substeps);
    if (stop_requested()) {
      StateReader in(snapshot_.data(), "(frame snapshot)");
      load_state(in);
      interrupted_ = true;
    }
    const auto start = Clock::now();
    fill_stats(stats);
    stats_total_ms_ += ms_since(start);
  } else {
    // Guard.h: snapshot, run, check; a rejected frame is rolled back and retried with twice the substeps.
    auto start = Clock::now();
    if (!start_sample_) {
      FrameStats s0;
      fill_stats(s0);
      start_sample_ = guard_sample(s0);
      if (budget_ref_ < 0.0) {  // the energy budget's reference: the start of the run (Guard.h)
        budget_ref_ = std::max(s0.kinetic + std::max(0.0, s0.elastic), guard_weight_scale(setup_, cloths_));
        budget_potential0_ = s0.potential;
      }
    }
    snapshot_.clear();
    save_state(snapshot_);
    guard_ms_ += ms_since(start);
    failure_.clear();
    long steps = 0;  // solver steps of this frame, every try
    for (int attempt = 0;; ++attempt) {
      const long n = static_cast<long>(setup_.substeps) << attempt;
      steps += n;
      std::string why = run_substeps(static_cast<int>(n), true);
      if (stop_requested()) {  // back to the frame start, the frame neither accepted nor failed
        StateReader in(snapshot_.data(), "(frame snapshot)");
        const GuardSample kept = *start_sample_;
        load_state(in);
        start_sample_ = kept;
        interrupted_ = true;
        fill_stats(stats);
        break;
      }
      start = Clock::now();
      stats = FrameStats();
      fill_stats(stats);
      stats_total_ms_ += ms_since(start);
      // The weil drape is a geometric shape, not a motion: the elastic energy of its edges (compressed where
      // the cloth folds) is none a step converted, so only the finite and strain criteria apply to it.
      const bool geometric = setup_.solver.method == "weil";
      GuardSettings bounds = setup_.guard;
      if (geometric) bounds.energy_growth = HUGE_VAL;
      if (why.empty()) why = guard_violation(bounds, *start_sample_, guard_sample(stats), energy_scale_);
      double pin_work = 0.0;
      if (why.empty() && setup_.guard.energy_bound > 0.0 && !geometric)
        why = energy_budget_violation(stats, &pin_work);
      if (why.empty()) {
        pin_work_ += pin_work;
        start_sample_ = guard_sample(stats);
        if (attempt > 0) ++retried_frames_;
        break;
      }
      start = Clock::now();
      StateReader in(snapshot_.data(), "(frame snapshot)");
      const GuardSample kept = *start_sample_;
      load_state(in);  // back to the frame start: the last good state
      start_sample_ = kept;
      guard_ms_ += ms_since(start);
      const bool capped = steps + 2 * n > kMaxStepsPerFrame;
      // The drape is the same shape at any number of substeps: no retry.
      if (attempt >= setup_.guard.max_halvings || capped || geometric) {
        ++failed_frames_;
        const bool out = output_frame_ > 0;  // the output frame's span, not this step's
        const double t0 = out ? (output_frame_ - 1) * output_frame_dt_ : t_;
        const double t1 = out ? output_frame_ * output_frame_dt_ : (frame_ + 1) * setup_.frame_dt;
        failure_ = why + " in frame " + std::to_string(out ? output_frame_ : frame_ + 1) +
                   " (t = " + std::to_string(t0) + " to " + std::to_string(t1) + " s)" +
                   (geometric ? std::string(", the weil drape's one shape")
                              : ", also with " + std::to_string(n) + " substeps");
        if (capped && attempt < setup_.guard.max_halvings)
          failure_ += "; no further retry: one with " + std::to_string(2 * n) + " substeps would bring the " +
                      "frame to " + std::to_string(steps + 2 * n) + " solver steps, above the " +
                      std::to_string(kMaxStepsPerFrame) + " a frame may take (guard.max_halvings)";
        if (why.rfind("the strain", 0) == 0) failure_ += moving_pin_note((frame_ + 1) * setup_.frame_dt);
        stats.finite = false;  // the frame failed; the simulation holds the last good frame
        break;
      }
      ++rollbacks_;
    }
  }
  const std::vector<StageProfile> after = profile();
  stats.stage_ms.resize(after.size());
  for (size_t k = 0; k < after.size(); ++k) {
    stats.stage_ms[k] = after[k].total_ms - (k < before.size() ? before[k].total_ms : 0.0);
    if (after[k].name.find('/') == std::string::npos) stats.total_ms += stats.stage_ms[k];
  }
  return stats;
}

std::string Simulation::energy_budget_violation(const FrameStats& end, double* pin_work) {
  // Guard.h: E(t) > energy_bound · max(E_kin(0) + E_el(0), Σ m|g|L) + W(t); W(t): kinematic vertices
  // |f·v| Δt and wind |f_drag| (|v| + |wind|) Δt per frame (at the frame end) and the stages' work_in().
  double w = 0.0;
  for (auto& c : cloths_) {
    const ClothState& st = c->state();
    bool kinematic = false;
    for (int i = 0; i < st.size() && !kinematic; ++i) kinematic = st.inv_mass[i] == 0.0;
    if (kinematic) {
      Vec3s f;
      c->compute_forces(st.x, st.v, t_, setup_.threads, f);
      for (int i = 0; i < st.size(); ++i)
        if (st.inv_mass[i] == 0.0) w += std::abs(f[i].dot(st.v[i])) * setup_.frame_dt;
    }
    if (const Term* drag = c->find_term("drag")) {  // wind: |f_drag| (|v| + |wind| (1 + gusts)) Δt per vertex
      Vec3s fd(st.size(), Vec3::Zero());
      drag->add_forces(EvalContext{st.x, st.v, t_, setup_.threads}, fd);
      const double wind = setup_.drag->wind.norm() * (1.0 + std::abs(setup_.drag->gust_amplitude));
      for (int i = 0; i < st.size(); ++i) w += fd[i].norm() * (st.v[i].norm() + wind) * setup_.frame_dt;
    }
    // Aero: |f_aero| (|v| + max |w|) Δt per vertex; pressure: |f_p| |v| Δt per vertex.
    for (const char* name : {"aero", "pressure"}) {
      const Term* term = c->find_term(name);
      if (!term) continue;
      Vec3s fa(st.size(), Vec3::Zero());
      term->add_forces(EvalContext{st.x, st.v, t_, setup_.threads}, fa);
      const double wind = setup_.wind && std::string(name) == "aero" ? setup_.wind->max_speed() : 0.0;
      for (int i = 0; i < st.size(); ++i) w += fa[i].norm() * (st.v[i].norm() + wind) * setup_.frame_dt;
    }
  }
  *pin_work = w;
  double stage_work = 0.0;
  for (const auto& stage : stages_) stage_work += stage->work_in();
  const double e = end.kinetic + end.elastic + end.potential - budget_potential0_;
  const double bound = setup_.guard.energy_bound * budget_ref_ + pin_work_ + w + stage_work;
  if (e <= bound) return "";
  std::ostringstream why;
  why << "the energy exploded (E_kin + E_el + E_pot - E_pot(0) = " << e << " J, above the budget " << bound
      << " J: guard.energy_bound " << setup_.guard.energy_bound << " x " << budget_ref_
      << " J at the start + " << pin_work_ + w + stage_work << " J of work put in)";
  return why.str();
}

FrameStats Simulation::measure() const {
  FrameStats stats;
  fill_stats(stats);
  stats.stage_ms.assign(stage_names().size(), 0.0);
  return stats;
}

namespace {
// Per-chunk partial results of the frame statistics, combined in chunk order: the same bits for any thread
// count.
struct StatChunk {
  double kinetic = 0.0, potential = 0.0, strain_sum = 0.0, max_strain = 0.0;
};
constexpr int kStatChunk = 512;

// chunks[ch] = fill(begin, end, chunk) over [0, n) in kStatChunk pieces, on several threads for large n.
template <class F>
void stat_chunks(int n, int threads, std::vector<StatChunk>& chunks, const F& fill) {
  const int count = (n + kStatChunk - 1) / kStatChunk;
  chunks.assign(count, StatChunk());
  // One thread runs without OpenMP (the end of a parallel region costs a system call even for one thread).
  if (!(threads > 1 && n >= kParallelMinVertices)) {
    for (int ch = 0; ch < count; ++ch) fill(ch * kStatChunk, std::min(n, (ch + 1) * kStatChunk), chunks[ch]);
    return;
  }
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int ch = 0; ch < count; ++ch) fill(ch * kStatChunk, std::min(n, (ch + 1) * kStatChunk), chunks[ch]);
}
}  // namespace

void Simulation::fill_stats(FrameStats& s) const {
  s.frame = frame_;
  s.time = t_;
  double strain_sum = 0.0;
  long strain_count = 0;
  std::vector<StatChunk> chunks;
  for (const auto& c : cloths_) {
    const ClothState& st = c->state();
    if (!st.is_finite()) s.finite = false;
    stat_chunks(st.size(), setup_.threads, chunks, [&](int begin, int end, StatChunk& out) {
      for (int i = begin; i < end; ++i) {
        out.kinetic += 0.5 * st.mass[i] * st.v[i].squaredNorm();
        out.potential -= st.mass[i] * setup_.gravity.dot(st.x[i]);
      }
    });
    for (const StatChunk& ch : chunks) {
      s.kinetic += ch.kinetic;
      s.potential += ch.potential;
    }
    s.elastic += c->elastic_energy(setup_.threads);
    const auto& springs = c->mesh().springs();
    const std::vector<int>& ids = c->mesh().strain_springs();
    stat_chunks(static_cast<int>(ids.size()), setup_.threads, chunks,
                [&](int begin, int end, StatChunk& out) {
                  for (int q = begin; q < end; ++q) {
                    const SpringDef& d = springs[ids[q]];
                    const double strain = (st.x[d.j] - st.x[d.i]).norm() / d.rest_length - 1.0;
                    out.max_strain =
                        std::max(out.max_strain, strain);  // a NaN strain is skipped here, caught by the sum
                    // The mean of the stretch the max counts (compression is not strain here), so
                    // max_strain >= mean_strain in every frame; a NaN strain is kept.
                    out.strain_sum += strain < 0.0 ? 0.0 : strain;
                  }
                });
    for (const StatChunk& ch : chunks) {
      s.max_strain = std::max(s.max_strain, ch.max_strain);
      strain_sum += ch.strain_sum;
    }
    strain_count += static_cast<long>(ids.size());
  }
  s.mean_strain = strain_count ? strain_sum / strain_count : 0.0;
  if (!std::isfinite(s.kinetic) || !std::isfinite(s.potential) || !std::isfinite(s.elastic) ||
      !std::isfinite(s.max_strain) || !std::isfinite(s.mean_strain))
    s.finite = false;
}

std::string Simulation::moving_pin_note(double t) const {
  double farthest = 0.0;
  const PinSpec* which = nullptr;
  const ClothSetup* owner = nullptr;
  std::string field;
  for (const ClothSetup& cs : setup_.cloths)
    for (size_t k = 0; k < cs.pins.size(); ++k) {
      const PinSpec& p = cs.pins[k];
      if (p.times.empty()) continue;
      Pin path;  // anchor zero: target(t) - target(0) is the pin's displacement
      path.times = p.times;
      path.offsets = p.offsets;
      const double d = (path.target(t) - path.target(0.0)).norm();
      if (d > farthest || !which) {
        farthest = d, which = &p, owner = &cs;
        field = k < cs.pin_fields.size() ? cs.pin_fields[k] + " " : "";
      }
    }
  if (!which) return "";
  std::ostringstream s;
  s << "; the moving pin " << field << "(cloth '" << owner->name << "', vertex " << which->vertex
    << ") has moved " << farthest
    << " m from its start by then: check its path against the cloth's size and guard.max_strain";
  return s.str();
}

}  // namespace loom::cloth
