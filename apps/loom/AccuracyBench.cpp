#include "AccuracyBench.h"

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

#include "AccuracyPlot.h"
#include "AccuracySweep.h"
#include "RealtimeBench.h"
#include "loom/bullet/BulletTwin.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Material.h"
#include "loom/cloth/CurvedFaces.h"
#include "loom/cloth/Simulation.h"
#include "loom/cloth/SpringSet.h"

namespace loom::app {

namespace {

using namespace loom::cloth;
using Clock = std::chrono::steady_clock;

constexpr double kFrameDt = 1.0 / 60.0;  // s
constexpr double kSize = 1.0;            // m, side of the square
constexpr double kMass = 0.2;            // kg
// Reference: Verlet (velocity form, reference()) at h_bound / (2 kRefFactor), checked against
// h_bound / kRefFactor (methods.md §2.4 proposes h_crit / 20; h_bound is already below h_crit). The finest
// Verlet of the sweep runs at h_bound, so for a second-order scheme the check ratio is about
// (3/4) / kRefFactor² = 0.3%.
constexpr int kRefFactor = 16;

// The hanging-cloth scene (issue 3): 1 m square of the cotton preset, 0.2 kg, horizontal, pinned at the
// two corners of one edge, damping off (so energy drift is meaningful).
struct Scene {
  int n = 0;
  int frames = 0;
  ClothSetup cloth;
  Vec3 gravity{0.0, -9.81, 0.0};
  std::vector<double> mass;     // kg per vertex
  std::vector<Spring> springs;  // Loom's springs (damping 0)
  Vec3s start;                  // m, start positions: the flat grid plus a smooth out-of-plane perturbation
  int explicit_steps = 1;       // steps per frame at the conservative explicit bound
  double h_bound = 0.0;         // s
};

// Conservative explicit stability bound h = 2 / ω_max with ω_max² bounded by Gershgorin's theorem on
// M^-1/2 K M^-1/2 (row i: Σ_j k_ij / m_i + Σ_j k_ij / sqrt(m_i m_j)); methods.md §2.1.
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
      s.start[s.cloth.mesh->grid_index(iu, iv)].y() += perturbation * std::sin(kPi * u) * std::sin(0.5 * kPi * v);
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

struct Row {
  std::string system, method, config;
  int size = 0, threads = 1;
  double ms_per_frame = 0.0, rms_error_max = 0.0, rms_error_end = 0.0, max_strain = 0.0, mean_strain = 0.0,
         energy_drift = 0.0;
  bool diverged = false;
};

// Per-frame metrics of one run, the same code for Loom and Bullet positions.
class Metrics {
 public:
  // `own`: a Loom cloth whose model is not the scene's springs; its own elastic energy is used (issue 10).
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
    for (size_t i = 0; i < x.size(); ++i) e += 0.5 * s_.mass[i] * v[i].squaredNorm() - s_.mass[i] * s_.gravity.dot(x[i]);
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
// two nearly equal positions whose rounding error, ulp(x) / h in velocity, grows as h shrinks. Measured on
// this scene (reference_check.csv, README): at h_bound/16 vs /32 position Verlet changed by 2.4e-8 m (N=32)
// and 1.1e-5 m (N=64: the buckling sheet amplifies it), i.e. did not converge; the velocity form changes by
// 4.9e-9 m and 5.5e-9 m, a quarter of the previous halving's change (second order).
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

// Hybrid detail (issue 10, Oshita & Makinouchi 2001): the same scene simulated on a coarse grid of
// (N - 1)/4 + 1 nodes per side with `c`, shown as its curved-face surface refined twice (CurvedFaces.h), and
// compared with the N x N reference at the reference's nodes (the shown surface bilinearly interpolated on its
// fine grid at each node's material point). Time: coarse step + surface rebuild.
Row run_hybrid(const Scene& s, const std::string& method, SweepConfig c, const std::vector<Vec3s>& ref, double duration,
               double perturbation) {
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
  if (std::isnan(v)) return "nan";
  char b[64];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

void print_row(const Row& r) {
  std::printf("  %-17s %-17s N=%-3d thr=%d %-36s %9s ms/frame  err max %-10s end %-10s strain max %-9s mean %-9s drift %-9s%s\n",
              r.system.c_str(), r.method.c_str(), r.size, r.threads, r.config.c_str(), num(r.ms_per_frame).c_str(),
              num(r.rms_error_max).c_str(), num(r.rms_error_end).c_str(), num(r.max_strain).c_str(),
              num(r.mean_strain).c_str(), num(r.energy_drift).c_str(), r.diverged ? "  DIVERGED" : "");
  std::fflush(stdout);
}

// Static scenes (issue 10): the catenary strip (methods.md §3.2; S = 1 m, spans 0.5, 0.8, 0.9 m; B ≈ 0) for the
// solvers that give a shape rather than a motion: weil (geometric drape) and static (energy minimisation).
// Row: size = nodes along the strip, config "scene=catenary span=D", ms_per_frame = wall time to the shape,
// rms_error_max = rms_error_end = |sag - analytic sag| (m), strains of the shape, energy_drift 0.
void run_static_scenes(const AccuracyOptions& o, const std::vector<std::string>& registered, std::vector<Row>& rows) {
  const std::vector<std::pair<double, double>> spans =
      o.quick ? std::vector<std::pair<double, double>>{{0.8, 0.26544}}
              : std::vector<std::pair<double, double>>{{0.5, 0.39819}, {0.8, 0.26544}, {0.9, 0.19071}};
  const int nodes = o.quick ? 26 : 101;
  bool header = false;
  for (const char* method : {"weil", "static"}) {
    if (std::find(registered.begin(), registered.end(), method) == registered.end()) continue;
    if (!o.methods.empty() && !o.methods.count(method)) continue;
    if (!header) {
      std::printf("loom bench accuracy: static scenes, catenary strip S = 1 m (%d x 2 nodes, 1 cm wide, cotton with "
                  "B ~ 0), error = |sag - analytic sag|\n", nodes);
      header = true;
    }
    for (const auto& [d, sag_ref] : spans) {
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
      r.config = "scene=catenary span=" + num(d);
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

}  // namespace

int bench_accuracy(const AccuracyOptions& o) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) {
    std::cerr << "loom: error: " << o.out << ": cannot create folder: " << ec.message() << "\n";
    return 1;
  }
  const std::vector<std::string> registered = solver_names();
  std::vector<Row> rows;
  std::ostringstream refs;
  refs << "size,ref_substeps,check_substeps,ref_change,smallest_error,ratio,passed,ref_max_strain\n";
  // Rewritten after every size, so a long run keeps what it measured.
  auto write_results = [&]() {
    std::ofstream csv(fs::path(o.out) / "accuracy.csv");
    csv << "system,method,size,config,threads,ms_per_frame,rms_error_max,rms_error_end,max_strain,mean_strain,energy_drift,diverged\n";
    for (const Row& r : rows)
      csv << r.system << ',' << r.method << ',' << r.size << ',' << r.config << ',' << r.threads << ','
          << num(r.ms_per_frame) << ',' << num(r.rms_error_max) << ',' << num(r.rms_error_end) << ','
          << num(r.max_strain) << ',' << num(r.mean_strain) << ',' << num(r.energy_drift) << ','
          << (r.diverged ? 1 : 0) << "\n";
    std::ofstream rf(fs::path(o.out) / "reference_check.csv");
    rf << refs.str();
    if (!csv || !rf) {
      std::cerr << "loom: error: " << o.out << ": cannot write the results\n";
      return false;
    }
    return true;
  };
  for (int n : o.sizes) {
    const Scene s = make_scene(n, o.duration, o.perturbation);
    const auto table = loom_sweep_table(s.explicit_steps, o.quick);
    std::printf("loom bench accuracy: N=%d (%d vertices, %zu springs), %d frames of 1/60 s, explicit bound h=%.3g s "
                "(%d steps/frame)\n", n, s.cloth.mesh->num_vertices(), s.springs.size(), s.frames, s.h_bound,
                s.explicit_steps);
    // Reference and its dt-halving check (methods.md §2.4).
    int ref_steps = kRefFactor * s.explicit_steps;  // the check; the reference itself runs at twice this
    const int threads_ref = 1;  // small meshes: OpenMP overhead exceeds the gain; results are identical
    auto t0 = Clock::now();
    const std::vector<Vec3s> coarse = reference(s, ref_steps, threads_ref);
    ref_steps *= 2;
    const std::vector<Vec3s> ref = reference(s, ref_steps, threads_ref);
    double change = 0.0;
    for (int f = 0; f < s.frames; ++f) change = std::max(change, rms(s.mass, coarse[f], ref[f]));
    // The reference's own largest structural stretch over the run (the strain target of issue 3).
    double ref_max_strain = 0.0;
    for (const Vec3s& x : ref)
      for (int k : s.cloth.mesh->strain_springs()) {
        const SpringDef& d = s.cloth.mesh->springs()[k];
        ref_max_strain = std::max(ref_max_strain, (x[d.j] - x[d.i]).norm() / d.rest_length - 1.0);
      }
    std::printf("  reference: velocity verlet, %d steps/frame, check at %d (%.1f s): they differ by %.3g m\n", ref_steps,
                ref_steps / 2, std::chrono::duration<double>(Clock::now() - t0).count(), change);
    std::fflush(stdout);

    const size_t first = rows.size();
    std::vector<std::string> skipped_methods;
    for (const auto& kv : table)
      if (std::find(registered.begin(), registered.end(), kv.first) == registered.end())
        skipped_methods.push_back(kv.first);
    for (const std::string& method : registered) {
      if (!o.methods.empty() && !o.methods.count(method)) continue;
      if (static_only(method)) continue;  // static scenes only (the catenary table below)
      std::vector<SweepConfig> configs;
      auto it = table.find(method);
      if (it != table.end()) {
        configs = it->second;
      } else {
        // A solver this table does not know yet: a default step sweep.
        for (int st : {1, 4}) configs.push_back(SweepConfig{st, {}, ""});
        if (o.quick) configs.resize(1);
        std::printf("  note: no sweep table entry for '%s'; using substeps 1, 4\n", method.c_str());
      }
      for (const SweepConfig& c : configs) {
        if (!o.configs.empty() && c.label().find(o.configs) == std::string::npos) continue;
        // Each row runs `repeats` times, the thread counts interleaved so that a slow spell of the machine
        // does not fall on one thread count only; the fastest run is kept. Results are bit-identical for
        // any thread count and run (STYLE): a repeat or a thread count that differs is reported.
        std::vector<std::optional<Row>> best(o.threads.size());
        std::optional<Row> diverged;
        bool skipped = false;
        for (int rep = 0; rep < o.repeats && !skipped; ++rep)
          for (size_t ti = 0; ti < o.threads.size() && !skipped; ++ti) {
            if (diverged) {
              // The run diverges again at any thread count; timing a state full of NaN means nothing. The
              // row stays, diverged, without a time.
              if (!best[ti]) {
                best[ti] = *diverged;
                best[ti]->threads = o.threads[ti];
                best[ti]->ms_per_frame = std::nan("");
              }
              continue;
            }
            try {
              const Row r = run_loom(s, method, c, o.threads[ti], ref);
              if (r.diverged) diverged = r;
              if (!best[ti]) {
                best[ti] = r;
              } else {
                if (!same_results(*best[ti], r))
                  std::printf("  warning: %s %s on %d threads: results differ between repeats\n",
                              method.c_str(), c.label().c_str(), r.threads);
                best[ti]->ms_per_frame = std::min(best[ti]->ms_per_frame, r.ms_per_frame);
              }
            } catch (const loom::Error& e) {
              std::printf("  skipped %s %s: %s\n", method.c_str(), c.label().c_str(), e.what());
              skipped = true;
            }
          }
        for (size_t ti = 1; ti < best.size(); ++ti)
          if (best[0] && best[ti] && !same_results(*best[0], *best[ti]))
            std::printf("  warning: %s %s: results differ between %d and %d threads\n", method.c_str(),
                        c.label().c_str(), o.threads[0], o.threads[ti]);
        for (const std::optional<Row>& r : best)
          if (r) {
            rows.push_back(*r);
            print_row(rows.back());
          }
      }
    }
    // Issue 10: the hybrid (coarse simulation + curved-face detail) with backward Euler and IMEX.
    if ((s.n - 1) / 4 + 1 >= 3)
      for (const char* method : {"implicit_euler", "imex"}) {
        if (!o.methods.empty() && !o.methods.count(method) && !o.methods.count("hybrid")) continue;
        if (std::find(registered.begin(), registered.end(), method) == registered.end()) continue;
        for (int st : o.quick ? std::vector<int>{1} : std::vector<int>{1, 4}) {
          SweepConfig c;
          c.substeps = st;
          c.params["cg_tolerance"] = 1e-4;
          rows.push_back(run_hybrid(s, method, c, ref, o.duration, o.perturbation));
          print_row(rows.back());
        }
      }
    for (const auto& kv : bullet_sweep_table(o.quick)) {
      if (!o.methods.empty() && !o.methods.count(kv.first)) continue;
      const auto kind = kv.first == "bullet_classic" ? bullet::TwinKind::kClassic : bullet::TwinKind::kDeformable;
      for (const SweepConfig& c : kv.second) {
        rows.push_back(run_bullet(s, kind, c, ref));
        print_row(rows.back());
      }
    }
    if (!skipped_methods.empty()) {
      std::printf("  skipped (not registered in this build):");
      for (const auto& m : skipped_methods) std::printf(" %s", m.c_str());
      std::printf("\n");
    }
    // Reference check against the smallest error reported at this size.
    double smallest = 1e300;
    for (size_t k = first; k < rows.size(); ++k)
      for (double e : {rows[k].rms_error_max, rows[k].rms_error_end})
        if (std::isfinite(e) && e > 0.0) smallest = std::min(smallest, e);
    const double ratio = change / smallest;
    const bool passed = ratio < 0.01;
    std::printf("reference check N=%d: halving the reference step (%d -> %d steps/frame) changes it by %.3g m "
                "(max over frames, mass-weighted RMS); smallest reported error %.3g m; ratio %.3g%% -> %s; "
                "reference max strain %.4g\n",
                n, ref_steps / 2, ref_steps, change, smallest, 100.0 * ratio, passed ? "PASSED (< 1%)" : "FAILED (>= 1%)", ref_max_strain);
    refs << n << ',' << ref_steps << ',' << ref_steps / 2 << ',' << num(change) << ',' << num(smallest) << ','
         << num(ratio) << ',' << (passed ? 1 : 0) << ',' << num(ref_max_strain) << "\n";
    std::vector<PlotPoint> pts;
    for (size_t k = first; k < rows.size(); ++k) {
      const Row& r = rows[k];
      if (r.threads != 1 || r.diverged || !(r.rms_error_max > 0.0)) continue;
      std::string label = r.system == "loom" ? "loom:" + r.method : r.system;
      const size_t model_at = r.config.find(" model=");
      if (model_at != std::string::npos) label += "+" + r.config.substr(model_at + 7);  // e.g. +corotated_fem
      if (r.config.find(" detail=") != std::string::npos) label += "+detail";
      pts.push_back({label, r.ms_per_frame, r.rms_error_max});
    }
    const std::string png = (fs::path(o.out) / ("accuracy_" + std::to_string(n) + ".png")).string();
    const std::string title = "hanging cloth " + std::to_string(n) + "x" + std::to_string(n) +
                              ", cotton, 1 m, 0.2 kg, " + num(o.duration) + " s, damping off";
    if (!write_results()) return 1;
    if (plot_accuracy(pts, title, png) && n == o.sizes.back()) fs::copy_file(png, fs::path(o.out) / "accuracy.png", fs::copy_options::overwrite_existing, ec);
  }
  run_static_scenes(o, registered, rows);
  if (!write_results()) return 1;
  std::printf("wrote %s/accuracy.csv, %s/reference_check.csv, %s/accuracy.png\n", o.out.c_str(), o.out.c_str(),
              o.out.c_str());
  return 0;
}

namespace {

// clang-format off
const char* kBenchUsage =
    "Usage: loom bench realtime [options]  (tiers vs Bullet on the character and sheet: loom bench realtime --help)\n"
    "       loom bench accuracy [--sizes 32,64,128] [--out DIR] [--quick] [--duration S] [--threads 1,2]\n"
    "                           [--methods LIST] [--configs TEXT] [--repeats R]\n"
    "\n"
    "The accuracy-vs-time benchmark on the hanging-cloth scene (1 m cotton square, 0.2 kg, two corners pinned,\n"
    "released horizontally, 60 Hz frames, damping off). Every registered solver runs over its knob sweep, and\n"
    "both Bullet twins (classic btSoftBody, deformable world) over iterations and substeps, against a reference\n"
    "(Verlet far below the explicit stability bound, checked by halving its step).\n"
    "Writes DIR/accuracy.csv (system,method,size,config,threads,ms_per_frame,rms_error_max,rms_error_end,\n"
    "max_strain,mean_strain,energy_drift,diverged), DIR/reference_check.csv, DIR/accuracy_N.png per size and\n"
    "DIR/accuracy.png (the last size).\n"
    "\n"
    "Options:\n"
    "  --sizes LIST    nodes per side (default 32,64)\n"
    "  --out DIR       output folder (default out/bench_accuracy)\n"
    "  --quick         tiny run for tests: N=8, 0.25 s, one configuration per method\n"
    "  --duration S    simulated seconds (default 0.25; longer runs lose a converged reference)\n"
    "  --threads LIST  thread counts for Loom's solvers (default 1,2)\n"
    "  --perturbation M  amplitude of the start bump that fixes the buckling direction (default 0.001 m)\n"
    "  --methods LIST  only these solvers / bullet_classic / bullet_deformable (default: all)\n"
    "  --configs TEXT  only the Loom configurations whose label contains TEXT, e.g. 'substeps=1 cg_tolerance=0.02'\n"
    "  --repeats R     run each Loom row R times, thread counts interleaved, and keep the fastest (default 1;\n"
    "                  for thread ratios on a shared machine); a repeat with other results is reported\n";
// clang-format on

bool parse_list(const std::string& s, std::vector<int>& out, int min) {
  out.clear();
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const long v = std::strtol(item.c_str(), &end, 10);
    if (item.empty() || *end || v < min || v > 4096) return false;
    out.push_back(static_cast<int>(v));
  }
  return !out.empty();
}

}  // namespace

int bench_main(int argc, char** argv) {
  if (argc < 3 || !std::strcmp(argv[2], "-h") || !std::strcmp(argv[2], "--help")) {
    std::cout << kBenchUsage;
    return argc < 3 ? 2 : 0;
  }
  if (std::strcmp(argv[2], "realtime") == 0) return bench_realtime(argc, argv);
  if (std::strcmp(argv[2], "accuracy") != 0) {
    std::fprintf(stderr, "loom: error: unknown benchmark '%s' (see loom bench --help)\n", argv[2]);
    return 2;
  }
  AccuracyOptions o;
  bool sizes_given = false, duration_given = false;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "loom: error: %s needs a value (see loom bench --help)\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "-h" || a == "--help") {
      std::cout << kBenchUsage;
      return 0;
    } else if (a == "--sizes") {
      const std::string v = value();
      if (!parse_list(v, o.sizes, 3)) {
        std::fprintf(stderr, "loom: error: --sizes expects a comma-separated list of integers >= 3, got '%s'\n", v.c_str());
        return 2;
      }
      sizes_given = true;
    } else if (a == "--threads") {
      const std::string v = value();
      if (!parse_list(v, o.threads, 1)) {
        std::fprintf(stderr, "loom: error: --threads expects a comma-separated list of integers >= 1, got '%s'\n", v.c_str());
        return 2;
      }
    } else if (a == "--methods") {
      for (const std::string& m : [](std::string v) {
             std::vector<std::string> out;
             std::stringstream ss(v);
             std::string item;
             while (std::getline(ss, item, ',')) out.push_back(item);
             return out;
           }(value()))
        o.methods.insert(m);
    } else if (a == "--configs") {
      o.configs = value();
    } else if (a == "--out") {
      o.out = value();
    } else if (a == "--duration") {
      const std::string v = value();
      char* end = nullptr;
      o.duration = std::strtod(v.c_str(), &end);
      if (v.empty() || *end || !(o.duration > 0.0) || o.duration > 60.0) {
        std::fprintf(stderr, "loom: error: --duration expects seconds in (0, 60], got '%s'\n", v.c_str());
        return 2;
      }
      duration_given = true;
    } else if (a == "--perturbation") {
      const std::string v = value();
      char* end = nullptr;
      o.perturbation = std::strtod(v.c_str(), &end);
      if (v.empty() || *end || !(o.perturbation >= 0.0) || o.perturbation > 0.1) {
        std::fprintf(stderr, "loom: error: --perturbation expects metres in [0, 0.1], got '%s'\n", v.c_str());
        return 2;
      }
    } else if (a == "--repeats") {
      const std::string v = value();
      std::vector<int> r;
      if (!parse_list(v, r, 1) || r.size() != 1) {
        std::fprintf(stderr, "loom: error: --repeats expects one integer in [1, 4096], got '%s'\n",
                     v.c_str());
        return 2;
      }
      o.repeats = r[0];
    } else if (a == "--quick") {
      o.quick = true;
    } else {
      std::fprintf(stderr, "loom: error: unknown option '%s' (see loom bench --help)\n", a.c_str());
      return 2;
    }
  }
  if (o.quick) {
    if (!sizes_given) o.sizes = {8};
    if (!duration_given) o.duration = 0.25;
  }
  return bench_accuracy(o);
}

}  // namespace loom::app
