// The accuracy benchmark's scene, reference and runs (AccuracyBenchInternal.h).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <set>
#include <sstream>

#include "AccuracyBenchInternal.h"
#include "loom/bullet/BulletTwin.h"
#include "loom/cloth/CurvedFaces.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Material.h"
#include "loom/cloth/Simulation.h"
#include "loom/cloth/SpringSet.h"
#include "loom/eval/AccuracyPlot.h"
#include "loom/eval/AccuracySweep.h"

namespace loom::eval::accuracy {

using Clock = std::chrono::steady_clock;

// Conservative explicit stability bound h = 2 / ω_max with ω_max² bounded by Gershgorin's theorem on
// M^-1/2 K M^-1/2 (row i: Σ_j k_ij / m_i + Σ_j k_ij / sqrt(m_i m_j)); docs/references.md, "Time integration".
double explicit_bound(const Scene& s) {
  const int nv = static_cast<int>(s.mass.size());
  std::vector<double> row(nv, 0.0);
  for (const Spring& sp : s.springs) {
    const double mi = s.mass[sp.i], mj = s.mass[sp.j];
    row[sp.i] += sp.k / mi + sp.k / std::sqrt(mi * mj);
    row[sp.j] += sp.k / mj + sp.k / std::sqrt(mi * mj);
  }
  double w2 = 0.0;
  for (double r : row) w2 = std::max(w2, r);
  return 2.0 / std::sqrt(w2);
}

Scene make_scene(int n, double duration, double perturbation) {
  Scene s;
  s.n = n;
  s.frames = std::max(1, static_cast<int>(std::lround(duration / kFrameDt)));
  GridSpec g;
  g.size_u = g.size_v = kSize;
  g.nodes_u = g.nodes_v = n;
  g.plane = GridPlane::kXZ;
  g.origin = Vec3(-0.5, 1.5, -0.5);
  s.cloth.name = "sheet";
  s.cloth.mesh = ClothMesh::grid(g);
  s.cloth.material = material_preset("cotton");
  s.cloth.material.damping = 0.0;
  s.cloth.material.areal_density = kMass / s.cloth.mesh->total_area();
  s.cloth.pins = {PinSpec{s.cloth.mesh->grid_index(0, 0), {}, {}, {}},
                  PinSpec{s.cloth.mesh->grid_index(n - 1, 0), {}, {}, {}}};
  for (double a : s.cloth.mesh->vertex_areas()) s.mass.push_back(s.cloth.material.areal_density * a);
  // A perfectly flat sheet buckles in a direction picked by round-off, which differs between step sizes and
  // solvers; a deterministic bump y += A sin(pi u) sin(pi v / 2) (zero at the pinned edge) picks it instead,
  // as Bullet's CreatePatch `perturbation` argument does.
  const double kPi = 3.14159265358979323846;
  s.start = s.cloth.mesh->rest_positions();
  for (int iv = 0; iv < n; ++iv)
    for (int iu = 0; iu < n; ++iu) {
      const double u = iu / double(n - 1), v = iv / double(n - 1);
      s.start[s.cloth.mesh->grid_index(iu, iv)].y() +=
          perturbation * std::sin(kPi * u) * std::sin(0.5 * kPi * v);
    }
  s.springs = make_springs(*s.cloth.mesh, s.cloth.material);
  s.h_bound = explicit_bound(s);
  s.explicit_steps = static_cast<int>(std::ceil(kFrameDt / s.h_bound));
  return s;
}

// Mass-weighted RMS distance sqrt(Σ m_i |a_i - b_i|² / Σ m_i), m.
double rms(const std::vector<double>& m, const Vec3s& a, const Vec3s& b) {
  double num = 0.0, den = 0.0;
  for (size_t i = 0; i < m.size(); ++i) {
    num += m[i] * (a[i] - b[i]).squaredNorm();
    den += m[i];
  }
  return std::sqrt(num / den);
}

// Median of per-frame wall times (ms): robust against other processes on the shared cores.
double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t k = v.size() / 2;
  return v.size() % 2 ? v[k] : 0.5 * (v[k - 1] + v[k]);
}

// Per-frame metrics of one run, the same code for Loom and Bullet positions.
class Metrics {
 public:
  // `own`: a Loom cloth whose model is not the scene's springs; its own elastic energy is used.
  Metrics(const Scene& s, const Vec3s& x0, const Cloth* own = nullptr)
      : s_(s), x0_(x0), energy_term_(static_cast<int>(x0.size()), s.springs), own_(own) {
    const Vec3s v0(x0.size(), Vec3::Zero());
    e0_ = energy(x0, v0);
    for (double m : s.mass) total_mass_ += m;
    scale_ = total_mass_ * s.gravity.norm() * kSize;
  }

  // Returns false once the run has diverged: non-finite state, a node 10 m from its start (the cloth is 1 m),
  // strain above 1000%, or total energy up by more than 10x m g L.
  bool add_frame(const Vec3s& x, const Vec3s& v, const Vec3s* ref, bool alive = true) {
    bool ok = alive;
    for (size_t i = 0; i < x.size() && ok; ++i)
      ok = x[i].allFinite() && v[i].allFinite() && (x[i] - x0_[i]).norm() < 10.0;
    double mx = 0.0, sum = 0.0;
    const auto& sprs = s_.cloth.mesh->springs();
    const auto& ids = s_.cloth.mesh->strain_springs();
    for (int k : ids) {
      const double strain = (x[sprs[k].j] - x[sprs[k].i]).norm() / sprs[k].rest_length - 1.0;
      mx = std::max(mx, strain);
      sum += std::abs(strain);
    }
    if (!ok || !(mx < 10.0)) return diverge();
    const double de = energy(x, v) - e0_;
    if (!std::isfinite(de) || de > 10.0 * scale_) return diverge();
    drift_ = std::max(drift_, std::abs(de) / scale_);
    max_strain_ = std::max(max_strain_, mx);
    mean_sum_ += sum / std::max<size_t>(1, ids.size());
    ++frames_;
    if (ref) {
      end_error_ = rms(s_.mass, x, *ref);
      max_error_ = std::max(max_error_, end_error_);
    }
    return true;
  }

  void fill(Row& r) const {
    r.diverged = diverged_;
    const double nan = std::nan("");
    r.rms_error_max = diverged_ ? nan : max_error_;
    r.rms_error_end = diverged_ ? nan : end_error_;
    r.max_strain = diverged_ ? nan : max_strain_;
    r.mean_strain = diverged_ || frames_ == 0 ? nan : mean_sum_ / frames_;
    r.energy_drift = diverged_ ? nan : drift_;
  }

 private:
  bool diverge() {
    diverged_ = true;
    return false;
  }
  // Kinetic + gravitational (zero at y = 0) + spring energy, J.
  double energy(const Vec3s& x, const Vec3s& v) const {
    double e = own_ ? own_->elastic_energy(1) : energy_term_.energy(EvalContext{x, v, 0.0, 1});
    for (size_t i = 0; i < x.size(); ++i)
      e += 0.5 * s_.mass[i] * v[i].squaredNorm() - s_.mass[i] * s_.gravity.dot(x[i]);
    return e;
  }

  const Scene& s_;
  Vec3s x0_;
  SpringTerm energy_term_;
  const Cloth* own_ = nullptr;
  double e0_ = 0.0, total_mass_ = 0.0, scale_ = 1.0;
  double max_error_ = 0.0, end_error_ = 0.0, max_strain_ = 0.0, mean_sum_ = 0.0, drift_ = 0.0;
  int frames_ = 0;
  bool diverged_ = false;
};

SimulationSetup loom_setup(const Scene& s, const std::string& method, const SweepConfig& c, int threads) {
  SimulationSetup setup;
  setup.cloths = {s.cloth};
  setup.gravity = s.gravity;
  if (!c.model.empty()) setup.cloths[0].model = c.model;
  setup.solver.method = method;
  setup.solver.params = c.params;
  // The real-time tier's long-range attachments to the pins (TetherStage.h), as the configuration key
  // "tether_slack" (not the solver's).
  auto slack = setup.solver.params.find("tether_slack");
  if (slack != setup.solver.params.end()) {
    setup.tethers = cloth::TetherSettings{slack->second, true};
    setup.solver.params.erase(slack);
  }
  // Provot's strain limit after the solver, every step (StrainLimitStage.h), as the configuration keys
  // "strain_limit" (τ: largest l/L - 1 it leaves) and "strain_limit_sweeps" (Gauss-Seidel sweeps per step,
  // default 4) and "strain_limit_outward" (1: sweeps outward from the pins), not the solver's.
  auto limit = setup.solver.params.find("strain_limit");
  if (limit != setup.solver.params.end()) {
    cloth::StrainLimitSettings sl;
    sl.max_stretch = limit->second;
    setup.solver.params.erase(limit);
    auto sweeps = setup.solver.params.find("strain_limit_sweeps");
    if (sweeps != setup.solver.params.end()) {
      sl.iterations = static_cast<int>(sweeps->second);
      setup.solver.params.erase(sweeps);
    }
    auto outward = setup.solver.params.find("strain_limit_outward");
    if (outward != setup.solver.params.end()) {
      sl.outward = outward->second != 0.0;
      setup.solver.params.erase(outward);
    }
    setup.strain_limit = sl;
  }
  setup.frame_dt = kFrameDt;
  setup.substeps = c.substeps;
  setup.threads = threads;
  // The explosion guard (Guard.h) would roll a diverging frame back and rerun it with twice the substeps, so
  // a configuration would be measured as another one: off, a run that blows up is reported as diverged.
  setup.guard.enabled = false;
  return setup;
}

// Pipeline time of the frame: top-level stages without the statistics row (ms).
double step_ms(const Simulation& sim, const FrameStats& st) {
  const std::vector<std::string> names = sim.stage_names();
  double ms = 0.0;
  for (size_t k = 0; k < names.size() && k < st.stage_ms.size(); ++k)
    if (names[k].find('/') == std::string::npos && names[k] != "stats") ms += st.stage_ms[k];
  return ms;
}

// Reference trajectory: positions at frames 1..frames.
// Moves the simulation's cloth to the scene's start positions (pinned vertices are not moved: the bump is 0
// there).
void set_start(Simulation& sim, const Scene& s) {
  ClothState& st = sim.cloths()[0]->state();
  for (int i = 0; i < st.size(); ++i)
    if (st.inv_mass[i] != 0.0) st.x[i] = s.start[i];
  st.x_prev = st.x;
}

// Reference trajectory: positions at frames 1..frames. Verlet in its velocity (kick-drift-kick) form on the
// scene's own cloth (Loom's terms: the same springs and gravity every run uses):
//   v += h/2 M⁻¹ f(x),  x += h v,  v += h/2 M⁻¹ f(x).
// Its positions are those of position Verlet x+ = 2x - x- + h² M⁻¹ f (the `verlet` solver, same start) in
// exact arithmetic, but it keeps v explicitly: position Verlet stores the velocity as x - x-, a difference of
// two nearly equal positions whose rounding error, ulp(x) / h in velocity, grows as h shrinks. On this scene
// position Verlet does not converge under step halving (the buckling sheet amplifies the rounding), while
// the velocity form changes by a quarter per halving, second order (reference_check.csv; docs/benchmarks.md).
std::vector<Vec3s> reference(const Scene& s, int substeps, int threads) {
  SweepConfig c;
  c.substeps = substeps;
  Simulation sim(loom_setup(s, "verlet", c, threads));  // builds the cloth: model, masses, pins
  set_start(sim, s);
  Cloth& cloth = *sim.cloths()[0];
  ClothState& st = cloth.state();
  const int nv = st.size();
  const double h = kFrameDt / substeps;
  Vec3s f;
  cloth.compute_forces(st.x, st.v, 0.0, threads, f);
  std::vector<Vec3s> out;
  for (int fr = 0; fr < s.frames; ++fr) {
    for (int k = 0; k < substeps; ++k) {
      const double t1 = (static_cast<double>(fr) * substeps + k + 1) * h;
      for (int i = 0; i < nv; ++i)
        if (st.inv_mass[i] != 0.0) {  // the scene's pins are fixed
          st.v[i] += 0.5 * h * st.inv_mass[i] * f[i];
          st.x[i] += h * st.v[i];
        }
      cloth.compute_forces(st.x, st.v, t1, threads, f);
      for (int i = 0; i < nv; ++i)
        if (st.inv_mass[i] != 0.0) st.v[i] += 0.5 * h * st.inv_mass[i] * f[i];
    }
    out.push_back(st.x);
    if (!st.is_finite()) throw Error("", "bench accuracy", "the reference diverged");
  }
  return out;
}

// The same accuracy figures, bit for bit (NaN equal to NaN): two runs of one configuration.
bool same_results(const Row& a, const Row& b) {
  auto same = [](double x, double y) { return x == y || (std::isnan(x) && std::isnan(y)); };
  return same(a.rms_error_max, b.rms_error_max) && same(a.rms_error_end, b.rms_error_end) &&
         same(a.max_strain, b.max_strain) && same(a.mean_strain, b.mean_strain) &&
         same(a.energy_drift, b.energy_drift) && a.diverged == b.diverged;
}

Row run_loom(const Scene& s, const std::string& method, const SweepConfig& c, int threads,
             const std::vector<Vec3s>& ref) {
  Simulation sim(loom_setup(s, method, c, threads));
  set_start(sim, s);
  ClothState& st = sim.cloths()[0]->state();
  Metrics m(s, st.x, c.model.empty() || c.model == "springs" ? nullptr : sim.cloths()[0].get());
  Row r;
  std::vector<double> ms;
  for (int f = 0; f < s.frames; ++f) {
    const FrameStats fs = sim.step_frame();
    ms.push_back(step_ms(sim, fs));
    if (!m.add_frame(st.x, st.v, &ref[f])) break;
  }
  r.system = "loom";
  r.method = method;
  r.size = s.n;
  r.config = c.label();
  r.threads = threads;
  r.ms_per_frame = median(ms);
  m.fill(r);
  return r;
}

// Hybrid detail (Oshita & Makinouchi 2001): the same scene simulated on a coarse grid of
// (N - 1)/4 + 1 nodes per side with `c`, shown as its curved-face surface refined twice (CurvedFaces.h), and
// compared with the N x N reference at the reference's nodes (the shown surface bilinearly interpolated on
// its fine grid at each node's material point). Time: coarse step + surface rebuild.
Row run_hybrid(const Scene& s, const std::string& method, SweepConfig c, const std::vector<Vec3s>& ref,
               double duration, double perturbation) {
  const int nc = (s.n - 1) / 4 + 1;
  const Scene coarse = make_scene(nc, duration, perturbation);
  Simulation sim(loom_setup(coarse, method, c, 1));
  set_start(sim, coarse);
  const CurvedFaces faces(sim.cloths()[0]->mesh(), 2);
  // The shown surface's vertices on its (4 (nc - 1) + 1)² grid, from their flat rest positions.
  const int m = 4 * (nc - 1) + 1;
  const Vec3s& rest = faces.fine_mesh()->rest_positions();
  std::vector<int> at(static_cast<size_t>(m) * m, -1);
  for (int i = 0; i < static_cast<int>(rest.size()); ++i) {
    const int p = static_cast<int>(std::lround((rest[i].x() + 0.5) / kSize * (m - 1)));
    const int q = static_cast<int>(std::lround((rest[i].z() + 0.5) / kSize * (m - 1)));
    at[static_cast<size_t>(q) * m + p] = i;
  }
  Vec3s shown, x(s.mass.size()), x_prev, v(s.mass.size(), Vec3::Zero());
  auto sample = [&]() {
    faces.evaluate(sim.cloths()[0]->state().x, shown);
    for (int iv = 0; iv < s.n; ++iv)
      for (int iu = 0; iu < s.n; ++iu) {
        const double fu = iu / double(s.n - 1) * (m - 1), fv = iv / double(s.n - 1) * (m - 1);
        const int p = std::min(static_cast<int>(fu), m - 2), q = std::min(static_cast<int>(fv), m - 2);
        const double a = fu - p, b = fv - q;
        auto P = [&](int dp, int dq) { return shown[at[static_cast<size_t>(q + dq) * m + p + dp]]; };
        x[s.cloth.mesh->grid_index(iu, iv)] =
            (1 - a) * (1 - b) * P(0, 0) + a * (1 - b) * P(1, 0) + (1 - a) * b * P(0, 1) + a * b * P(1, 1);
      }
  };
  sample();
  Metrics metrics(s, x);
  std::vector<double> ms;
  for (int f = 0; f < s.frames; ++f) {
    const FrameStats fs = sim.step_frame();
    const auto t0 = Clock::now();
    x_prev = x;
    sample();
    ms.push_back(step_ms(sim, fs) + std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    for (size_t i = 0; i < x.size(); ++i) v[i] = (x[i] - x_prev[i]) / kFrameDt;
    if (!metrics.add_frame(x, v, &ref[f], sim.cloths()[0]->state().is_finite())) break;
  }
  Row r;
  r.system = "loom";
  r.method = method;
  r.size = s.n;
  c.model.clear();
  r.config = c.label() + " detail=curved_faces levels=2 coarse=" + std::to_string(nc);
  r.threads = 1;
  r.ms_per_frame = median(ms);
  metrics.fill(r);
  return r;
}

Row run_bullet(const Scene& s, bullet::TwinKind kind, const SweepConfig& c, const std::vector<Vec3s>& ref) {
  bullet::TwinCloth tc;
  tc.mesh = s.cloth.mesh;
  tc.springs = s.springs;
  tc.masses = s.mass;
  for (const PinSpec& p : s.cloth.pins) tc.pinned.push_back(p.vertex);
  tc.gravity = s.gravity;
  tc.start = s.start;
  bullet::TwinSettings ts;
  ts.frame_dt = kFrameDt;
  ts.substeps = c.substeps;
  ts.iterations = static_cast<int>(c.params.count("iterations") ? c.params.at("iterations") : ts.iterations);
  bullet::BulletTwin twin(kind, tc, ts);
  Vec3s x, v;
  twin.positions(x);
  Metrics m(s, x);
  std::vector<double> ms;
  for (int f = 0; f < s.frames; ++f) {
    const auto start = Clock::now();
    twin.step_frame();
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    twin.positions(x);
    twin.velocities(v);
    if (!m.add_frame(x, v, &ref[f], twin.simulating())) break;
  }
  Row r;
  r.system = bullet::system_name(kind);
  r.method = r.system;
  r.size = s.n;
  r.config = c.label();
  r.threads = 1;
  r.ms_per_frame = median(ms);
  m.fill(r);
  return r;
}

std::string num(double v) {
  if (!std::isfinite(v)) return "-";  // a diverged run's figure: never "nan" on the terminal
  char b[64];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

void print_row(const Row& r) {
  std::printf(
      "  %-17s %-17s N=%-3d thr=%d %-36s %9s ms/frame  err max %-10s end %-10s strain max %-9s mean %-9s "
      "drift %-9s%s\n",
      r.system.c_str(), r.method.c_str(), r.size, r.threads, r.config.c_str(), num(r.ms_per_frame).c_str(),
      num(r.rms_error_max).c_str(), num(r.rms_error_end).c_str(), num(r.max_strain).c_str(),
      num(r.mean_strain).c_str(), num(r.energy_drift).c_str(), r.diverged ? "  DIVERGED" : "");
  std::fflush(stdout);
}

// Static scenes: the catenary strip (Weil 1986; docs/validation.md; S = 1 m, spans 0.5, 0.8, 0.9 m; B ≈ 0)
// for the solvers that give a shape rather than a motion: weil (geometric drape) and static (energy
// minimisation). Row: size = nodes along the strip, config "scene=catenary span=D", ms_per_frame = wall time
// to the shape, rms_error_max = rms_error_end = |sag - analytic sag| (m), strains of the shape, energy_drift
// 0.
void run_static_scenes(const AccuracyOptions& o, const std::vector<std::string>& registered,
                       std::vector<Row>& rows) {
  const std::vector<std::pair<double, double>> spans =
      o.quick ? std::vector<std::pair<double, double>>{{0.8, 0.26544}}
              : std::vector<std::pair<double, double>>{{0.5, 0.39819}, {0.8, 0.26544}, {0.9, 0.19071}};
  const int nodes = o.quick ? 26 : 101;
  bool header = false;
  for (const char* method : {"weil", "static"}) {
    if (std::find(registered.begin(), registered.end(), method) == registered.end()) continue;
    if (!o.methods.empty() && !o.methods.count(method)) continue;
    if (!header) {
      std::printf(
          "loom bench accuracy: static scenes, catenary strip S = 1 m (%d x 2 nodes, 1 cm wide, cotton with "
          "B ~ 0), error = |sag - analytic sag|\n",
          nodes);
      header = true;
    }
    for (const auto& [d, sag_ref] : spans) {
      // --configs selects these Loom rows by their label too.
      if (!o.configs.empty() && ("scene=catenary span=" + num(d)).find(o.configs) == std::string::npos)
        continue;
      SimulationSetup setup;
      ClothSetup c;
      GridSpec g;
      g.size_u = 1.0;
      g.size_v = 0.01;
      g.nodes_u = nodes;
      g.nodes_v = 2;
      g.origin = Vec3(-0.5, 1.0, 0.0);
      c.mesh = ClothMesh::grid(g);
      c.material = material_preset("cotton");
      c.material.bend_weft = c.material.bend_warp = 1e-10;  // N·m: the catenary has no bending
      c.material.damping = 0.0;
      for (int iv = 0; iv < 2; ++iv) {
        c.pins.push_back(PinSpec{c.mesh->grid_index(0, iv), Vec3(-0.5 * d, 1.0, 0.01 * iv), {}, {}});
        c.pins.push_back(PinSpec{c.mesh->grid_index(nodes - 1, iv), Vec3(0.5 * d, 1.0, 0.01 * iv), {}, {}});
      }
      setup.cloths = {c};
      setup.solver.method = method;
      setup.frame_dt = kFrameDt;
      Row r;
      r.system = "loom";
      r.method = method;
      r.size = nodes;
      r.config = "scene=catenary span=" + num(d);  // the label --configs matches
      r.threads = 1;
      try {
        Simulation sim(setup);
        const auto start = Clock::now();
        sim.step_frame();
        r.ms_per_frame = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
        const ClothState& st = sim.cloths()[0]->state();
        double lowest = 1e300;
        for (const Vec3& p : st.x) lowest = std::min(lowest, p.y());
        const double err = std::abs((1.0 - lowest) - sag_ref);
        r.diverged = !st.is_finite() || !std::isfinite(err);
        r.rms_error_max = r.rms_error_end = err;
        double mx = 0.0, sum = 0.0;
        const auto& sprs = c.mesh->springs();
        for (int k : c.mesh->strain_springs()) {
          const double strain = (st.x[sprs[k].j] - st.x[sprs[k].i]).norm() / sprs[k].rest_length - 1.0;
          mx = std::max(mx, strain);
          sum += std::abs(strain);
        }
        r.max_strain = mx;
        r.mean_strain = sum / std::max<size_t>(1, c.mesh->strain_springs().size());
        r.energy_drift = 0.0;
      } catch (const loom::Error& e) {
        std::printf("  skipped %s %s: %s\n", method, r.config.c_str(), e.what());
        continue;
      }
      rows.push_back(r);
      print_row(rows.back());
    }
  }
}

}  // namespace loom::eval::accuracy
