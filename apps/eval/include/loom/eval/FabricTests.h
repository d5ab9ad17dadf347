#pragma once
// Virtual fabric tests: the standard textile measurements run in simulation and compared with theory
// (docs/validation.md, "Fabric tests"):
//  - cantilever (ASTM D1388 / FAST-2): a 25 mm strip clamped at one end and bent by its weight; tip chord
//  angle
//    against the exact inextensible elastica θ'' = -(l/c)³ (1 - s) cos θ, θ(0) = 0, θ'(1) = 0, with the
//    bending length c = (B / (ρ_A g))^(1/3); the measured angle, inverted through the elastica, gives c and
//    B.
//  - tensile (FAST-3): a 20 cm x 5 cm strip pulled along the weft at 5, 20 and 100 gf/cm; extension E5, E20,
//    E100 (%) and the modulus F / ε at 5 gf/cm against the material's stretch modulus.
//  - shear (bias extension): the same strip cut at 45° to warp and weft, pulled at 5 gf/cm; with the
//    orthotropic compliance 1/E45 = (1/E1 + 1/E2 + 1/G) / 4 the shear modulus G = 1 / (4/E45 - 1/E1 - 1/E2).
//  - catenary: a narrow strip of length S = 1 m hung between two points at span d; sag against
//    a (cosh(d/2a) - 1) with S = 2a sinh(d/2a).
//  - drape (Cusick, BS 5058): a 30 cm disc (concentric-ring mesh, `resolution` rings, the support edge half a
//    ring spacing inside the last held ring) held on an 18 cm support; drape coefficient DC = (A_s -
//    A_d)/(A_D - A_d) x 100 from the projected shadow area (point sampled at 0.5 mm) and the number of nodes
//    (rim radius peaks >= 3 mm prominent). No published DC exists for the presets (docs/validation.md):
//    theory and error are NaN (null in --json).
// Static measurements use the static (energy-minimisation) solver; each test reports measured, theory,
// error, and its own fields.
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "loom/cloth/Material.h"

namespace loom::eval {
using namespace loom::cloth;

// --resolution's range: below 5 nodes the strip has no shape to compare with the theory.
constexpr int kMinFabricResolution = 5, kMaxFabricResolution = 2000;

struct FabricTestOptions {
  std::string test = "cantilever";  // cantilever | tensile | shear | catenary | drape
  Material material;
  std::string model = "springs";  // a model_names() entry
  int resolution = 0;             // nodes along the strip; 0 = the test's default
  double overhang_ratio = 2.0;    // cantilever: l / c
  double span = 0.8;              // catenary: d (m), with S = 1 m
  int threads = 1;
  // "static" (energy minimisation, the default) or any dynamic solver, which then runs frames of
  // `settle_dt` seconds with damping until it has settled — for 3 frames in a row the largest vertex speed
  // over a frame and at its end below `settle_speed` — or `settle_frames` frames have passed, so the result
  // can be compared with the static one. Unsettled (or a failed frame): the test measures nothing (NaN).
  std::string solver = "static";
  int settle_frames = 400;
  double settle_dt = 0.01;     // s
  double settle_speed = 1e-6;  // m/s, dynamic solvers: settled when every vertex moves slower than this
  // The model is the test's default, not a choice of the caller (named so in a refusal).
  bool model_is_default = false;
  // Called once, after the test's scene is built and checked and before it runs: a scene the solver refuses
  // (a model term it cannot use, a specimen or load it cannot take) throws loom::Error naming --solver and
  // --model before this, so a command can claim its output here and a refused run leaves none.
  std::function<void()> on_ready;
};

struct FabricTestResult {
  std::string test, material, model, solver;
  int resolution = 0;
  std::string quantity, unit;  // what measured/theory are, e.g. "tip chord angle", "deg"
  double measured = 0.0, theory = 0.0, error = 0.0;    // error = measured - theory (same unit)
  std::vector<std::pair<std::string, double>> fields;  // the test's own numbers
  // Curves for the report's plot: simulated and theoretical (x, y) points.
  std::vector<std::pair<double, double>> curve, theory_curve;
  double seconds = 0.0;      // s, wall time of the simulation (set-up and solve/settle; not the theory)
  double cpu_seconds = 0.0;  // s, process CPU time of the same (the comparable figure on a busy machine)
  // Settling: frames run (summed over a test's pulls; a pull that did not settle ends the test, and then they
  // are that pull's frames, at most settle_frames), and for dynamic solvers whether the speed fell below
  // settle_speed before settle_frames; for the static solver these are its static solves (one a frame) and
  // whether the largest move of the last one met the test's tolerance (converged), not a settling.
  int settle_frames = 0;
  bool settled = false;
  // Why the run measured nothing although frames were left: a frame the simulation failed (its cause and
  // frame, Simulation::failure()) or a static solve that did not converge. "" otherwise; when set, measured,
  // error, the measured fields and the simulated curve are NaN / empty.
  std::string failure;
  // The step of a test of several (tensile's pulls) that did not settle, e.g. "the 20 gf/cm pull"; "" else.
  std::string unsettled_in;
};

std::vector<std::string> fabric_test_names();
// fabric_test_names() as "cantilever, tensile, ...": every list of the tests shown to a user.
std::string fabric_test_list();
// Throws loom::Error naming the option (or "test") for an unknown test, solver or model, or an option out of
// range; run_fabric_test checks the same, so a command can refuse its options before it writes anything.
void check_fabric_test_options(const FabricTestOptions& options);
// Throws loom::Error for an unknown test or option out of range (check_fabric_test_options), and naming
// --solver for a scene the solver refuses (FabricTestOptions::on_ready).
FabricTestResult run_fabric_test(const FabricTestOptions& options);

// Exact inextensible elastica: tip chord angle (degrees) of a cantilever with overhang ratio l/c, and the
// ratio that gives a chord angle (inverse).
double elastica_chord_angle(double overhang_ratio);
double elastica_overhang_ratio(double chord_angle_deg);
// Catenary of a chain of length S hung at span d (same height): the parameter a of y = a cosh(x/a), with
// S = 2a sinh(d/2a), and the sag a (cosh(d/2a) - 1).
double catenary_parameter(double length, double span);
double catenary_sag(double length, double span);

}  // namespace loom::eval
