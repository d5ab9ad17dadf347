#include "loom/eval/FabricTests.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>
#include <memory>
#include <set>
#include <sstream>

#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/LoadTerm.h"
#include "loom/cloth/Model.h"
#include "loom/cloth/Simulation.h"
#include "loom/cloth/StaticSolver.h"
#include "loom/scene/SceneLimits.h"

namespace loom::eval {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kG = 9.81;                   // m/s²
constexpr double kGramForcePerCm = 0.980665;  // N/m in 1 gf/cm

// Integrates the cantilever elastica θ'' = -λ³ (1 - s) cos θ on s in [0, 1] from θ(0) = 0, θ'(0) = a
// (RK4); returns θ'(1) and fills the shape (x, y down) if asked.
double elastica_shoot(double lambda3, double a, std::vector<std::pair<double, double>>* shape = nullptr) {
  const int steps = 2000;
  const double h = 1.0 / steps;
  double th = 0.0, om = a, x = 0.0, y = 0.0;
  auto acc = [&](double s, double t) { return -lambda3 * (1.0 - s) * std::cos(t); };
  if (shape) shape->assign(1, {0.0, 0.0});
  for (int k = 0; k < steps; ++k) {
    const double s = k * h;
    // State (θ, ω, x, y): x' = cos θ, y' = sin θ.
    const double k1t = om, k1o = acc(s, th), k1x = std::cos(th), k1y = std::sin(th);
    const double t2 = th + 0.5 * h * k1t, o2 = om + 0.5 * h * k1o;
    const double k2t = o2, k2o = acc(s + 0.5 * h, t2), k2x = std::cos(t2), k2y = std::sin(t2);
    const double t3 = th + 0.5 * h * k2t, o3 = om + 0.5 * h * k2o;
    const double k3t = o3, k3o = acc(s + 0.5 * h, t3), k3x = std::cos(t3), k3y = std::sin(t3);
    const double t4 = th + h * k3t, o4 = om + h * k3o;
    const double k4t = o4, k4o = acc(s + h, t4), k4x = std::cos(t4), k4y = std::sin(t4);
    th += h / 6 * (k1t + 2 * k2t + 2 * k3t + k4t);
    om += h / 6 * (k1o + 2 * k2o + 2 * k3o + k4o);
    x += h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
    y += h / 6 * (k1y + 2 * k2y + 2 * k3y + k4y);
    if (shape && (k + 1) % 20 == 0) shape->emplace_back(x, y);
  }
  if (shape) shape->emplace_back(x, y);
  return om;
}

// Solves the shooting problem θ'(1) = 0 and returns the shape (x, y down), unit overhang.
std::vector<std::pair<double, double>> elastica_shape(double ratio) {
  const double lambda3 = ratio * ratio * ratio;
  double lo = 0.0, hi = 0.5 * lambda3 + 1e-12;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (elastica_shoot(lambda3, mid) < 0.0)
      lo = mid;
    else
      hi = mid;
  }
  std::vector<std::pair<double, double>> shape;
  elastica_shoot(lambda3, 0.5 * (lo + hi), &shape);
  return shape;
}

struct Strip {
  std::shared_ptr<const ClothMesh> mesh;
  int nu = 0, nv = 0;
};

// A strip along x in the horizontal XZ plane: nu x nv nodes with square cells of side d, node (0, 0) at
// origin.
Strip grid_strip(int nu, int nv, double d, const Vec3& origin) {
  GridSpec g;
  g.nodes_u = nu;
  g.nodes_v = nv;
  g.size_u = d * (nu - 1);
  g.size_v = d * (nv - 1);
  g.plane = GridPlane::kXZ;
  g.origin = origin;
  return {ClothMesh::grid(g), nu, nv};
}

// A strip of equilateral triangles along x in the XZ plane: rows i at x = origin.x + i h (h = √3/2 d),
// nv nodes across at z = origin.z + j d, odd rows shifted by d/2. Right-triangle grids make dihedral and
// hinge bending anisotropic, with soft modes that creases along the cheaper direction exploit
// (Bridson, Marino & Fedkiw 2003; docs/references.md); equilateral meshes do not. Nodes are numbered like a
// grid (index = j nu + i), so centre() and pin_row() work unchanged.
Strip equilateral_strip(int nu, int nv, double d, const Vec3& origin) {
  const double h = 0.5 * std::sqrt(3.0) * d;
  Vec3s x(static_cast<size_t>(nu) * nv);
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) x[j * nu + i] = origin + Vec3(i * h, 0.0, j * d + (i % 2 ? 0.5 * d : 0.0));
  std::vector<Tri> tris;
  for (int i = 0; i + 1 < nu; ++i)
    for (int j = 0; j + 1 < nv; ++j) {
      const int a = j * nu + i, b = j * nu + i + 1, c = (j + 1) * nu + i, e = (j + 1) * nu + i + 1;
      if (i % 2 == 0) {  // row i unshifted, row i+1 shifted up by d/2
        tris.push_back({a, b, c});
        tris.push_back({b, e, c});
      } else {
        tris.push_back({a, b, e});
        tris.push_back({a, e, c});
      }
    }
  return {ClothMesh::from_triangles(std::move(x), std::move(tris), {}, "equilateral strip"), nu, nv};
}

SimulationSetup static_setup(const Strip& strip, const FabricTestOptions& o, const Vec3& gravity) {
  SimulationSetup s;
  ClothSetup c;
  c.name = o.test;
  c.mesh = strip.mesh;
  c.material = o.material;
  c.model = o.model;
  s.cloths.push_back(c);
  s.gravity = gravity;
  s.solver.method = o.solver;
  if (o.solver == "static") {
    s.solver.params["iterations"] = 200;
    s.frame_dt = 1.0;
  } else {
    s.frame_dt = o.settle_dt;
    s.cloths[0].material.damping = std::max(s.cloths[0].material.damping, 0.05);  // settle quickly
  }
  s.substeps = 1;
  s.threads = o.threads;
  return s;
}

void pin_row(SimulationSetup& s, const Strip& strip, int iu) {
  for (int iv = 0; iv < strip.nv; ++iv) s.cloths[0].pins.push_back(PinSpec{iv * strip.nu + iu, {}, {}, {}});
}

// Position of the strip's centre line at row iu (the middle node, or the mean of the two middle nodes).
Vec3 centre(const ClothState& st, const Strip& strip, int iu) {
  const int a = (strip.nv - 1) / 2, b = strip.nv / 2;
  return 0.5 * (st.x[a * strip.nu + iu] + st.x[b * strip.nu + iu]);
}

// Wall and CPU clocks around the simulation part of a test (set-up and settling, not the theory).
struct SolveTimer {
  std::chrono::steady_clock::time_point wall = std::chrono::steady_clock::now();
  std::clock_t cpu = std::clock();
  void stop(FabricTestResult& r) const {
    r.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - wall).count();
    r.cpu_seconds += static_cast<double>(std::clock() - cpu) / CLOCKS_PER_SEC;
  }
};

// Set while run_fabric_test tries other --model / --solver values for a refusal's advice: build() then
// stops a test right after its scene is built (throwing TrialBuilt) and gives no advice of its own.
thread_local bool t_trial = false;
struct TrialBuilt {};

std::string listed(const std::vector<std::string>& names) {
  std::string s;
  for (size_t k = 0; k < names.size(); ++k)
    s += (k == 0 ? "" : k + 1 == names.size() ? " or " : ", ") + names[k];
  return s;
}

// Whether the test builds its scene with these options (at the smallest resolution: which solver takes which
// model does not depend on it).
bool builds(FabricTestOptions o) {
  o.resolution = kMinFabricResolution;
  o.on_ready = nullptr;
  t_trial = true;
  bool ok = false;
  try {
    run_fabric_test(o);
  } catch (const TrialBuilt&) {
    ok = true;
  } catch (const Error&) {
  }
  t_trial = false;
  return ok;
}

// The test's simulation, built and checked; then o.on_ready (the CLI claims its report folder there). A
// scene the options made but the solver refuses (a model term it cannot use, a specimen or load it cannot
// take) is an error of the options: thrown naming --solver and --model, with the values that work instead.
std::unique_ptr<Simulation> build(const SimulationSetup& s, const FabricTestOptions& o) {
  std::unique_ptr<Simulation> sim;
  try {
    sim = std::make_unique<Simulation>(s);
  } catch (const Error& e) {
    if (t_trial) throw;
    std::string why = e.what();  // "FIELD: PROBLEM": the scene's field means nothing to the command's user
    const size_t colon = why.find(": ");
    if (colon != std::string::npos && why.find(' ') > colon) why = why.substr(colon + 2);
    std::vector<std::string> models, solvers;
    for (const std::string& m : model_names()) {
      FabricTestOptions t = o;
      t.model = m;
      if (m != o.model && builds(t)) models.push_back(m);
    }
    for (const std::string& m : solver_names()) {
      FabricTestOptions t = o;
      t.solver = m;
      if (m != o.solver && builds(t)) solvers.push_back(m);
    }
    std::string advice;
    if (!models.empty()) advice = "give --model " + listed(models);
    if (!solvers.empty())
      advice += (advice.empty() ? "give " : ", or ") + std::string("--solver ") + listed(solvers) +
                " with --model " + o.model;
    throw Error("", "--solver",
                o.solver + " cannot run the " + o.test + " test with --model " + o.model +
                    (o.model_is_default ? " (the " + o.test + " default)" : "") + ": " + why +
                    (advice.empty() ? "" : "; " + advice));
  }
  if (t_trial) throw TrialBuilt{};
  if (o.on_ready) o.on_ready();
  return sim;
}

// Consecutive quiet frames a dynamic solver needs to be settled.
constexpr int kQuietFrames = 3;

// Runs frames until the cloth has settled; returns the frames used and records them (and whether it settled)
// in r. Static solver: until the largest vertex move in a frame is below tol (m), at most 8 frames (it needs
// one or a few). Dynamic solvers: until, for kQuietFrames frames in a row, every vertex moved less than
// o.settle_speed x o.settle_dt over the frame and ends it slower than o.settle_speed (m/s), at most
// o.settle_frames frames. A strip at rest that is about to fall (explicit Euler's first step moves nothing
// but gains speed) is not quiet, and a frame the simulation failed (it then holds its last good state, so
// nothing moves) ends the run unsettled.
int settle(Simulation& sim, double tol, const FabricTestOptions& o, FabricTestResult& r) {
  const bool dynamic = o.solver != "static";
  int max_frames = 8;
  if (dynamic) {
    tol = o.settle_speed * o.settle_dt;  // a per-frame move below this: speed below settle_speed
    max_frames = std::max(o.settle_frames, 1);
  }
  r.settled = false;
  int quiet = 0;
  for (int f = 1; f <= max_frames; ++f) {
    const Vec3s before = sim.cloths()[0]->state().x;
    const FrameStats stats = sim.step_frame();
    double moved = 0.0, speed = 0.0;
    const ClothState& st = sim.cloths()[0]->state();
    const Vec3s& after = st.x;
    for (size_t i = 0; i < after.size(); ++i) moved = std::max(moved, (after[i] - before[i]).norm());
    for (const Vec3& v : st.v) speed = std::max(speed, v.norm());
    if (!std::isfinite(moved) || !std::isfinite(speed))
      throw Error("", "fabric-test", "the simulation became non-finite");
    r.settle_frames = f;
    if (!stats.finite) {  // a failed frame (the guard's cause): not settled, and no frames can settle it
      r.failure = sim.failure();
      return f;
    }
    if (!dynamic) {
      if (moved < tol) {
        r.settled = true;
        return f;
      }
      continue;
    }
    quiet = moved < tol && speed < o.settle_speed ? quiet + 1 : 0;
    if (quiet >= kQuietFrames) {
      r.settled = true;
      return f;
    }
  }
  if (!dynamic) {
    std::ostringstream why;
    why << "the static solve did not converge: the largest vertex move was still above " << tol << " m after "
        << max_frames << " frames of Newton iterations (the shape it stopped at is no equilibrium)";
    r.failure = why.str();
  }
  return max_frames;
}

FabricTestResult cantilever(const FabricTestOptions& o) {
  FabricTestResult r;
  const Material& m = o.material;
  const double c =
      std::cbrt(m.bend_weft / (m.areal_density * kG));  // m, bending length (strip along the weft)
  const double l = o.overhang_ratio * c;                // m, overhang
  const int n = o.resolution > 0 ? o.resolution : 33;   // nodes along the overhang
  // Rows 0 and 1 are clamped. The first bending element sits at row 1 and stands for the cloth between
  // rows 0.5 and 1.5, so the discrete strip bends from row 0.5 on: the clamp edge x = 0 is put there and
  // the overhang runs from row 0.5 to row n (l = (n - 0.5) rows).
  const bool grid =
      o.model == "springs";  // Provot springs need the grid; the others get equilateral triangles
  const double row = l / (n - 0.5), d = grid ? row : row / (0.5 * std::sqrt(3.0));
  // 25 mm wide (ASTM D1388), and at least 16 cells across: the free side edges carry fewer bending elements,
  // a loss of about one cell's share of the width, which the elastica (per unit width) does not have.
  const int nv = std::max(17, static_cast<int>(std::lround(0.025 / d)) + 1);
  const Vec3 origin(-0.5 * row, 0.0, -0.5 * d * (nv - 1));
  const Strip strip = grid ? grid_strip(n + 1, nv, d, origin) : equilateral_strip(n + 1, nv, d, origin);
  SimulationSetup s = static_setup(strip, o, Vec3(0, -kG, 0));
  pin_row(s, strip, 0);
  pin_row(s, strip, 1);
  const SolveTimer timer;
  const std::unique_ptr<Simulation> sim = build(s, o);
  const int frames = settle(*sim, 1e-9 * l, o, r);
  timer.stop(r);
  const ClothState& st = sim->cloths()[0]->state();
  const Vec3 edge = 0.5 * (centre(st, strip, 0) + centre(st, strip, 1)), tip = centre(st, strip, n);
  r.quantity = "tip chord angle";
  r.unit = "deg";
  r.measured = std::atan2(edge.y() - tip.y(), tip.x() - edge.x()) * 180.0 / kPi;
  r.theory = elastica_chord_angle(o.overhang_ratio);
  r.error = r.measured - r.theory;
  const double c_measured = r.measured > 0.01 ? l / elastica_overhang_ratio(r.measured) : 0.0;
  r.fields = {{"overhang_ratio", o.overhang_ratio},
              {"overhang_m", l},
              {"bending_length_m", c},
              {"bending_length_measured_m", c_measured},
              {"rigidity_Nm", m.bend_weft},
              {"rigidity_measured_Nm", m.areal_density * kG * c_measured * c_measured * c_measured},
              {"static_frames", frames}};
  for (int iu = 0; iu <= n; ++iu) {
    const Vec3 p = centre(st, strip, iu);
    r.curve.emplace_back((p.x() - edge.x()) / l, (p.y() - edge.y()) / l);
  }
  for (const auto& [x, y] : elastica_shape(o.overhang_ratio)) r.theory_curve.emplace_back(x, -y);
  r.resolution = n;
  return r;
}

// Strip of length 20 cm and width 5 cm pulled along x by a line load F (N/m) on its far end; returns the
// strain of the far end, NaN when a dynamic solver did not settle (its frames recorded in r). `angle` not 0:
// the strip's material frame is given per triangle, rotated by it (bias cut).
double pulled_strain(const FabricTestOptions& o, double line_load, int n, double angle, FabricTestResult& r) {
  const double length = 0.2, width = 0.05, d = length / (n - 1);
  const int nv = static_cast<int>(std::lround(width / d)) + 1;
  Strip strip = grid_strip(n, nv, d, Vec3::Zero());
  if (angle != 0.0) {
    // The same geometry as a triangle mesh whose warp/weft frame is rotated by `angle` (bias cut).
    std::vector<std::array<Vec2, 3>> uvs;
    const Vec3s& x = strip.mesh->rest_positions();
    const double ca = std::cos(angle), sa = std::sin(angle);
    for (const Tri& t : strip.mesh->triangles()) {
      std::array<Vec2, 3> uv;
      for (int k = 0; k < 3; ++k)
        uv[k] = Vec2(ca * x[t[k]].x() + sa * x[t[k]].z(), -sa * x[t[k]].x() + ca * x[t[k]].z());
      uvs.push_back(uv);
    }
    strip.mesh = ClothMesh::from_triangles(x, strip.mesh->triangles(), uvs, "bias strip");
  }
  SimulationSetup s = static_setup(strip, o, Vec3::Zero());
  pin_row(s, strip, 0);
  const std::unique_ptr<Simulation> simp = build(s, o);
  Simulation& sim = *simp;
  // The clamp: the line load split over the end nodes (half weight at the two corners).
  std::vector<int> verts;
  Vec3s forces;
  for (int iv = 0; iv < nv; ++iv) {
    verts.push_back(iv * n + n - 1);
    const double share = (iv == 0 || iv == nv - 1) ? 0.5 : 1.0;
    forces.push_back(Vec3(line_load * width / (nv - 1) * share, 0, 0));
  }
  sim.cloths()[0]->add_term(std::make_unique<LoadTerm>(verts, forces));
  FabricTestResult settled;
  settle(sim, 1e-12, o, settled);
  // The test's record: frames over all its pulls, settled when every pull settled.
  r.settled = (r.settle_frames == 0 || r.settled) && settled.settled;
  r.settle_frames += settled.settle_frames;
  if (!settled.settled) {  // measured nothing (a failed frame, an unsettled run, a static solve that did not
                           // converge)
    r.settle_frames = settled.settle_frames;
    if (r.failure.empty()) r.failure = settled.failure;
    return std::numeric_limits<double>::quiet_NaN();
  }
  const ClothState& st = sim.cloths()[0]->state();
  double moved = 0.0;
  for (int v : verts) moved += st.x[v].x() - strip.mesh->rest_positions()[v].x();
  return moved / verts.size() / length;
}

FabricTestResult tensile(const FabricTestOptions& o) {
  FabricTestResult r;
  const int n = o.resolution > 0 ? o.resolution : 41;
  const double loads[3] = {5, 20, 100};  // gf/cm (FAST-3)
  double strain[3];
  // Each pull settles on its own, within o.settle_frames; the first that measures nothing ends the test
  // (r.settle_frames is then that pull's frames, r.unsettled_in names it).
  for (int k = 0; k < 3; ++k) {
    strain[k] = std::numeric_limits<double>::quiet_NaN();
    r.theory_curve.emplace_back(loads[k] * kGramForcePerCm / o.material.stretch_weft * 100.0, loads[k]);
  }
  for (int k = 0; k < 3; ++k) {
    strain[k] = pulled_strain(o, loads[k] * kGramForcePerCm, n, 0.0, r);
    if (!std::isfinite(strain[k])) {
      std::ostringstream pull;
      pull << "the " << loads[k] << " gf/cm pull";
      r.unsettled_in = pull.str();
      break;
    }
    r.curve.emplace_back(strain[k] * 100.0, loads[k]);
  }
  r.quantity = "stretch modulus at 5 gf/cm (weft)";
  r.unit = "N/m";
  // One pull that measured nothing (a failed or unsettled run) leaves the test without a measurement.
  const bool whole = std::isfinite(strain[0]) && std::isfinite(strain[1]) && std::isfinite(strain[2]);
  r.measured = whole ? 5 * kGramForcePerCm / strain[0] : std::numeric_limits<double>::quiet_NaN();
  r.theory = o.material.stretch_weft;
  r.error = r.measured - r.theory;
  r.fields = {{"E5_percent", strain[0] * 100},
              {"E20_percent", strain[1] * 100},
              {"E100_percent", strain[2] * 100},
              {"relative_error", r.measured / r.theory - 1.0}};
  r.resolution = n;
  return r;
}

FabricTestResult shear(const FabricTestOptions& o) {
  FabricTestResult r;
  const int n = o.resolution > 0 ? o.resolution : 41;
  const double strain5 = pulled_strain(o, 5 * kGramForcePerCm, n, 0.25 * kPi, r);
  if (!std::isfinite(strain5)) r.unsettled_in = "the 5 gf/cm pull";
  const double e45 = 5 * kGramForcePerCm / strain5;  // N/m
  const Material& m = o.material;
  const double inv_g = 4.0 / e45 - 1.0 / m.stretch_weft - 1.0 / m.stretch_warp;
  r.quantity = "shear modulus (bias extension)";
  r.unit = "N/m";
  r.measured = inv_g > 0 ? 1.0 / inv_g : std::numeric_limits<double>::infinity();
  r.theory = m.shear;
  r.error = r.measured - r.theory;
  r.fields = {{"EB5_percent", strain5 * 100},
              {"bias_modulus_Nm", e45},
              {"fast_shear_rigidity_Nm", 123.0 / (strain5 * 100)}};
  r.resolution = n;
  return r;
}

FabricTestResult catenary(const FabricTestOptions& o) {
  FabricTestResult r;
  const double S = 1.0, span = o.span;
  if (!(span > 0.0 && span < S)) throw Error("", "--span", "must be in (0, 1) m");
  const int n = o.resolution > 0 ? o.resolution : 41;
  const double d = S / (n - 1);
  const Strip strip = grid_strip(n, 3, d, Vec3::Zero());
  // Start from a V of two straight arms of length S/2 (isometric to the flat strip).
  const double depth = std::sqrt(0.25 * S * S - 0.25 * span * span);
  auto v_shape = [&](double s, double z) {
    const double a = s <= 0.5 * S ? s / (0.5 * S) : (S - s) / (0.5 * S);
    const double x = s <= 0.5 * S ? -0.5 * span + a * 0.5 * span : 0.5 * span - a * 0.5 * span;
    return Vec3(x, -a * depth, z);
  };
  SimulationSetup s = static_setup(strip, o, Vec3(0, -kG, 0));
  for (int iv = 0; iv < 3; ++iv)
    for (int iu : {0, n - 1}) {
      const int v = iv * n + iu;
      s.cloths[0].pins.push_back(PinSpec{v, v_shape(iu * d, strip.mesh->rest_positions()[v].z()), {}, {}});
    }
  const SolveTimer timer;
  const std::unique_ptr<Simulation> simp = build(s, o);
  Simulation& sim = *simp;
  ClothState& st = sim.cloths()[0]->state();
  for (int v = 0; v < st.size(); ++v)
    if (st.inv_mass[v] != 0.0)
      st.x[v] = v_shape(strip.mesh->rest_positions()[v].x(), strip.mesh->rest_positions()[v].z());
  st.x_prev = st.x;
  settle(sim, 1e-10, o, r);
  timer.stop(r);
  double lowest = 0.0;
  for (int iu = 0; iu < n; ++iu) {
    const Vec3 p = centre(st, strip, iu);
    lowest = std::min(lowest, p.y());
    r.curve.emplace_back(p.x(), p.y());
  }
  const double sag = catenary_sag(S, span);
  // The analytic curve y = a cosh(x/a) - a cosh(d/2a).
  const double a = catenary_parameter(S, span);
  for (int k = 0; k <= 100; ++k) {
    const double x = -0.5 * span + span * k / 100.0;
    r.theory_curve.emplace_back(x, a * std::cosh(x / a) - a * std::cosh(span / (2 * a)));
  }
  r.quantity = "sag";
  r.unit = "m";
  r.measured = -lowest;
  r.theory = sag;
  r.error = r.measured - r.theory;
  r.fields = {{"span_m", span}, {"length_m", S}, {"relative_error", r.measured / r.theory - 1.0}};
  r.resolution = n;
  return r;
}

// A disc of radius R in the XZ plane at y = 0, centre at the origin: a centre node and `rings` rings, ring k
// with 6k nodes, triangulated between neighbouring rings by angle (nearly equilateral triangles, no preferred
// direction beyond the 6-fold ring start). The support edge r_s falls half a ring spacing h inside the last
// held ring ks = round(rings r_s / R): the first bending element sits on ring ks and stands for the cloth
// from r_s = r_ks - h/2 outwards (as the cantilever's clamp, row 0.5), so the skirt bends from r_s at every
// resolution. Rings evenly spaced inside r_ks and at spacing h outside. (With rings at kR/rings the last
// held ring would move with the ring count, and the drape coefficient with it.) `held_radius`: r_ks, every
// node within it is held.
std::shared_ptr<const ClothMesh> disc_mesh(double radius, int rings, double support_radius,
                                           double& held_radius) {
  const int ks = std::clamp(static_cast<int>(std::lround(rings * support_radius / radius)), 1, rings - 1);
  const double h = (radius - support_radius) / (rings - ks + 0.5);
  held_radius = support_radius + 0.5 * h;
  Vec3s x{Vec3::Zero()};
  std::vector<int> first{0};  // index of each ring's first node
  for (int k = 1; k <= rings; ++k) {
    first.push_back(static_cast<int>(x.size()));
    const double r = k <= ks ? held_radius * k / ks : held_radius + h * (k - ks);
    for (int m = 0; m < 6 * k; ++m) {
      const double a = 2.0 * kPi * m / (6 * k);
      x.push_back(Vec3(r * std::cos(a), 0.0, r * std::sin(a)));
    }
  }
  std::vector<Tri> tris;
  for (int k = 1; k <= rings; ++k) {
    const int n0 = k == 1 ? 1 : 6 * (k - 1), n1 = 6 * k;
    auto inner = [&](int q) { return first[k - 1] + q % n0; };
    auto outer = [&](int q) { return first[k] + q % n1; };
    int a = 0, b = 0;
    while (a < n0 || b < n1) {
      // Advance the ring whose next node comes first by angle (fractions of a turn, compared exactly).
      const bool step_outer =
          b < n1 && (a >= n0 || static_cast<long>(b + 1) * n0 <= static_cast<long>(a + 1) * n1);
      if (step_outer) {
        tris.push_back({inner(a), outer(b), outer(b + 1)});
        ++b;
      } else {
        tris.push_back({inner(a), outer(b), inner(a + 1)});
        ++a;
      }
      if (n0 == 1 && b >= n1) break;
    }
  }
  return ClothMesh::from_triangles(std::move(x), std::move(tris), {}, "drape disc");
}

// Area (m²) of the union of the triangles projected on the XZ plane, by point sampling on a `cell` grid.
double shadow_area(const Vec3s& x, const std::vector<Tri>& tris, double half_extent, double cell) {
  const int n = static_cast<int>(std::ceil(2.0 * half_extent / cell));
  std::vector<char> covered(static_cast<size_t>(n) * n, 0);
  for (const Tri& t : tris) {
    const Vec2 p[3] = {Vec2(x[t[0]].x(), x[t[0]].z()), Vec2(x[t[1]].x(), x[t[1]].z()),
                       Vec2(x[t[2]].x(), x[t[2]].z())};
    const double area2 = (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[1] - p[0]).y() * (p[2] - p[0]).x();
    if (area2 == 0.0) continue;
    const double lo_x = std::min({p[0].x(), p[1].x(), p[2].x()}),
                 hi_x = std::max({p[0].x(), p[1].x(), p[2].x()});
    const double lo_z = std::min({p[0].y(), p[1].y(), p[2].y()}),
                 hi_z = std::max({p[0].y(), p[1].y(), p[2].y()});
    const int i0 = std::max(0, static_cast<int>(std::floor((lo_x + half_extent) / cell)));
    const int i1 = std::min(n - 1, static_cast<int>(std::floor((hi_x + half_extent) / cell)));
    const int j0 = std::max(0, static_cast<int>(std::floor((lo_z + half_extent) / cell)));
    const int j1 = std::min(n - 1, static_cast<int>(std::floor((hi_z + half_extent) / cell)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const Vec2 q(-half_extent + (i + 0.5) * cell, -half_extent + (j + 0.5) * cell);
        double w[3];
        for (int e = 0; e < 3; ++e) {
          const Vec2 a = p[(e + 1) % 3] - q, b = p[(e + 2) % 3] - q;
          w[e] = (a.x() * b.y() - a.y() * b.x()) / area2;
        }
        if (w[0] >= 0 && w[1] >= 0 && w[2] >= 0) covered[static_cast<size_t>(j) * n + i] = 1;
      }
  }
  long count = 0;
  for (char c : covered) count += c;
  return count * cell * cell;
}

FabricTestResult drape(const FabricTestOptions& o) {
  FabricTestResult r;
  const double R = 0.15, r_support = 0.09;  // m: 30 cm specimen on an 18 cm support (Cusick, BS 5058)
  const int rings = o.resolution > 0 ? o.resolution : 20;
  double r_held = 0.0;  // m, the last held ring
  auto mesh = disc_mesh(R, rings, r_support, r_held);
  SimulationSetup s;
  ClothSetup c;
  c.name = "drape";
  c.mesh = mesh;
  c.material = o.material;
  c.model = o.model;
  // The support: every node on the 18 cm disc is held (the specimen is clamped between two discs).
  const Vec3s& rest = mesh->rest_positions();
  for (int v = 0; v < mesh->num_vertices(); ++v)
    if (rest[v].norm() <= r_held * (1.0 + 1e-9)) c.pins.push_back(PinSpec{v, {}, {}, {}});
  s.cloths.push_back(c);
  s.gravity = Vec3(0, -kG, 0);
  s.solver.method = o.solver;
  s.substeps = 1;
  s.threads = o.threads;
  if (o.solver == "static") {
    s.solver.params["iterations"] = 200;
    s.frame_dt = 1.0;
  } else {
    s.frame_dt = o.settle_dt;
    s.cloths[0].material.damping = std::max(s.cloths[0].material.damping, 0.05);
  }
  const std::unique_ptr<Simulation> simp = build(s, o);
  Simulation& sim = *simp;
  // Start: the skirt bent down around the support edge (a cone of 60°), with a small deterministic
  // waviness (amplitude 1 mm at the rim, 7 waves plus 3: no preferred node count) so folds can form.
  ClothState& st = sim.cloths()[0]->state();
  for (int v = 0; v < st.size(); ++v) {
    const double rr = rest[v].norm();
    if (rr <= r_held * (1.0 + 1e-9)) continue;
    const double a = std::atan2(rest[v].z(), rest[v].x()), t = rr - r_held;
    const double slope = kPi / 3.0,
                 wave = 1e-3 * (t / (R - r_held)) * (std::sin(7 * a) + 0.5 * std::sin(3 * a + 1.0));
    const double rad = r_held + t * std::cos(slope);
    st.x[v] = Vec3(rad * std::cos(a), -t * std::sin(slope) + wave, rad * std::sin(a));
  }
  st.x_prev = st.x;
  const int frames = settle(sim, 1e-7, o, r);
  // Shadow area, the disc's own (flat) area and the support area, all on the same sampling grid.
  const double cell = 0.5e-3;
  const double As = shadow_area(st.x, mesh->triangles(), R * 1.05, cell);
  const double AD = shadow_area(rest, mesh->triangles(), R * 1.05, cell);
  const double Ad = kPi * r_support * r_support;
  // Nodes: local maxima of the rim's projected radius against angle (outermost ring), at least 3 mm above
  // the neighbouring minima.
  const int rim0 = 1 + 3 * (rings - 1) * rings, rim_n = 6 * rings;
  std::vector<double> rim(rim_n);
  for (int m = 0; m < rim_n; ++m) rim[m] = Vec2(st.x[rim0 + m].x(), st.x[rim0 + m].z()).norm();
  int nodes = 0;
  for (int m = 0; m < rim_n; ++m) {
    const double here = rim[m];
    if (!(here > rim[(m - 1 + rim_n) % rim_n] && here >= rim[(m + 1) % rim_n])) continue;
    // Prominence: the lowest rim radius on each side before the rim rises above this peak again.
    double drop[2] = {0.0, 0.0};
    for (int side = 0; side < 2; ++side)
      for (int q = 1; q < rim_n; ++q) {
        const double other = rim[((side ? m + q : m - q) % rim_n + rim_n) % rim_n];
        if (other > here) break;
        drop[side] = std::max(drop[side], here - other);
      }
    if (std::min(drop[0], drop[1]) >= 3e-3) ++nodes;
  }
  double rim_min = 1e9, rim_max = 0.0, lowest = 0.0;
  for (double v : rim) {
    rim_min = std::min(rim_min, v);
    rim_max = std::max(rim_max, v);
  }
  for (const Vec3& p : st.x) lowest = std::min(lowest, p.y());
  for (int m = 0; m <= rim_n; ++m) {
    const Vec3& p = st.x[rim0 + m % rim_n];
    r.curve.emplace_back(p.x(), p.z());
    const double a = 2.0 * kPi * m / rim_n;
    r.theory_curve.emplace_back(R * std::cos(a), R * std::sin(a));  // the flat specimen's outline
  }
  r.quantity = "drape coefficient";
  r.unit = "%";
  r.measured = (As - Ad) / (AD - Ad) * 100.0;
  r.theory = std::numeric_limits<double>::quiet_NaN();  // no published DC for these fabrics
  r.error = std::numeric_limits<double>::quiet_NaN();
  r.fields = {{"nodes", nodes},
              {"shadow_area_m2", As},
              {"specimen_area_m2", AD},
              {"support_area_m2", Ad},
              {"rim_radius_min_m", rim_min},
              {"rim_radius_max_m", rim_max},
              {"lowest_point_m", lowest},
              {"bending_length_m", std::cbrt(0.5 * (o.material.bend_weft + o.material.bend_warp) /
                                             (o.material.areal_density * kG))},
              {"frames", frames},
              {"vertices", mesh->num_vertices()}};
  r.resolution = rings;
  return r;
}

}  // namespace

std::vector<std::string> fabric_test_names() {
  return {"cantilever", "tensile", "shear", "catenary", "drape"};
}

std::string fabric_test_list() {
  std::string list;
  for (const std::string& t : fabric_test_names()) list += (list.empty() ? "" : ", ") + t;
  return list;
}

void check_fabric_test_options(const FabricTestOptions& o) {
  const std::vector<std::string> tests = fabric_test_names();
  if (std::find(tests.begin(), tests.end(), o.test) == tests.end())
    throw Error("", "test",
                "unknown fabric test '" + show_value(o.test) + "' (known: " + fabric_test_list() + ")");
  if (o.resolution != 0 && (o.resolution < kMinFabricResolution || o.resolution > kMaxFabricResolution))
    throw Error("", "--resolution",
                "must be in [" + std::to_string(kMinFabricResolution) + ", " +
                    std::to_string(kMaxFabricResolution) + "]");
  // Memory before anything is built: every test's specimen has at most 4 n^2 vertices at resolution n (the
  // shear square n^2, the drape disc about 3 n^2, the strips fewer), each kBytesPerVertex (SceneLimits.h).
  // Without --resolution the test's default n is checked the same way.
  {
    const int given = o.resolution > 0         ? o.resolution
                      : o.test == "drape"      ? 20
                      : o.test == "cantilever" ? 33
                                               : 41;
    const double n = given, bytes = 4.0 * n * n * static_cast<double>(scene::kBytesPerVertex);
    scene::check_memory("", "--resolution", bytes,
                        (o.resolution > 0 ? "" : "the default ") + std::to_string(given) + " may need",
                        "give a smaller resolution");
  }
  if (!(o.overhang_ratio > 0.05 && o.overhang_ratio < 10.0))
    throw Error("", "--overhang-ratio", "must be in (0.05, 10)");
  const std::vector<std::string> solvers = solver_names();
  if (std::find(solvers.begin(), solvers.end(), o.solver) == solvers.end()) {
    std::string known;
    for (const std::string& s : solvers) known += (known.empty() ? "" : ", ") + s;
    throw Error("", "--solver", "unknown solver '" + show_value(o.solver) + "' (known: " + known + ")");
  }
  const std::vector<std::string> models = model_names();
  if (std::find(models.begin(), models.end(), o.model) == models.end())
    throw Error("", "--model", "unknown model '" + show_value(o.model) + "'");
}

FabricTestResult run_fabric_test(const FabricTestOptions& options) {
  check_fabric_test_options(options);
  // The caller's on_ready runs once, after the first of the test's scenes is built (tensile builds three).
  FabricTestOptions o = options;
  bool ready = false;
  o.on_ready = [&ready, &options]() {
    if (!ready && options.on_ready) options.on_ready();
    ready = true;
  };
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  FabricTestResult r;
  if (o.test == "cantilever") {
    r = cantilever(o);
  } else if (o.test == "tensile") {
    r = tensile(o);
  } else if (o.test == "shear") {
    r = shear(o);
  } else if (o.test == "catenary") {
    r = catenary(o);
  } else if (o.test == "drape") {
    r = drape(o);
  } else {
    throw Error("", "test",
                "unknown fabric test '" + show_value(o.test) + "' (known: " + fabric_test_list() + ")");
  }
  // A run that did not settle or failed measured nothing (tensile and shear: pulled_strain): no measured
  // figure, no simulated curve, no field derived from the final shape.
  if (!r.failure.empty() ||
      (!r.settled && (o.test == "cantilever" || o.test == "catenary" || o.test == "drape"))) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    r.measured = r.error = nan;
    r.curve.clear();
    const std::set<std::string> inputs = {"overhang_ratio", "overhang_m", "bending_length_m",
                                          "rigidity_Nm",    "span_m",     "length_m",
                                          "static_frames",  "frames",     "vertices"};
    for (auto& field : r.fields)
      if (!inputs.count(field.first)) field.second = nan;
  }
  r.test = o.test;
  r.material = o.material.name;
  r.model = o.model;
  r.solver = o.solver;
  if (r.seconds == 0.0) {  // tests without their own solve timer (tensile, shear: several solves)
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.cpu_seconds = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  }
  return r;
}

double elastica_chord_angle(double ratio) {
  const auto shape = elastica_shape(ratio);
  return std::atan2(shape.back().second, shape.back().first) * 180.0 / kPi;
}

double elastica_overhang_ratio(double angle) {
  // The chord angle grows monotonically with l/c: 85° is reached near l/c = 6.
  double lo = 0.01, hi = 8.0;
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (elastica_chord_angle(mid) < angle)
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

double catenary_parameter(double length, double span) {
  // S = 2a sinh(d/2a) decreases in a (towards d): bisection in log space.
  double lo = 1e-6, hi = 1e6;
  for (int it = 0; it < 200; ++it) {
    const double a = std::sqrt(lo * hi);
    if (2 * a * std::sinh(std::min(span / (2 * a), 700.0)) > length)
      lo = a;
    else
      hi = a;
  }
  return std::sqrt(lo * hi);
}

double catenary_sag(double length, double span) {
  const double a = catenary_parameter(length, span);
  return a * (std::cosh(span / (2 * a)) - 1.0);
}

}  // namespace loom::eval
