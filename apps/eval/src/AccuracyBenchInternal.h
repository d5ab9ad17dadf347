#pragma once
// Internals of `loom bench accuracy` shared by AccuracyBench.cpp (the command: sizes, rows, results) and
// AccuracyRuns.cpp (the scene, its reference and one run per system). Not installed.
#include <string>
#include <vector>

#include "loom/bullet/BulletTwin.h"
#include "loom/cloth/Simulation.h"
#include "loom/cloth/SpringSet.h"
#include "loom/eval/AccuracyBench.h"
#include "loom/eval/AccuracySweep.h"

namespace loom::eval::accuracy {

using namespace loom::cloth;

inline constexpr double kFrameDt = 1.0 / 60.0;  // s
inline constexpr double kSize = 1.0;            // m, side of the square
inline constexpr double kMass = 0.2;            // kg
// Reference: Verlet (velocity form, reference()) at h_bound / (2 kRefFactor), checked against
// h_bound / kRefFactor (docs/benchmarks.md proposes h_crit / 20; h_bound is already below h_crit). The finest
// Verlet of the sweep runs at h_bound, so for a second-order scheme the check ratio is about
// (3/4) / kRefFactor² = 0.3%.
inline constexpr int kRefFactor = 16;

// The hanging-cloth scene: 1 m square of the cotton preset, 0.2 kg, horizontal, pinned at the
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

// One row of accuracy.csv: a system's configuration at one size and thread count.
struct Row {
  std::string system, method, config;
  int size = 0, threads = 1;
  double ms_per_frame = 0.0, rms_error_max = 0.0, rms_error_end = 0.0, max_strain = 0.0, mean_strain = 0.0,
         energy_drift = 0.0;
  bool diverged = false;
};

// The scene at n x n nodes for `duration` s, with the out-of-plane start bump `perturbation` (m).
Scene make_scene(int n, double duration, double perturbation);
// Mass-weighted RMS distance (m) of two position sets.
double rms(const std::vector<double>& m, const Vec3s& a, const Vec3s& b);
// The reference positions at every frame: velocity Verlet at `substeps` steps per frame.
std::vector<Vec3s> reference(const Scene& s, int substeps, int threads);
// The same accuracy figures, bit for bit (NaN equal to NaN): two runs of one configuration.
bool same_results(const Row& a, const Row& b);
// One row per system: a Loom solver, the hybrid (coarse simulation + curved-face detail), a Bullet twin.
Row run_loom(const Scene& s, const std::string& method, const SweepConfig& c, int threads,
             const std::vector<Vec3s>& ref);
Row run_hybrid(const Scene& s, const std::string& method, SweepConfig c, const std::vector<Vec3s>& ref,
               double duration, double perturbation);
Row run_bullet(const Scene& s, bullet::TwinKind kind, const SweepConfig& c, const std::vector<Vec3s>& ref);
// A number for the CSV and the log ("nan" for NaN, else %.6g).
std::string num(double v);
void print_row(const Row& r);
// The static scenes' rows (catenary strip; weil and static solvers).
void run_static_scenes(const AccuracyOptions& o, const std::vector<std::string>& registered,
                       std::vector<Row>& rows);

}  // namespace loom::eval::accuracy
