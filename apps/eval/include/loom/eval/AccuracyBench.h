#pragma once
// `loom bench accuracy`: the accuracy-vs-time benchmark (docs/benchmarks.md) on the
// hanging-cloth scene — every registered Loom solver over its knob sweep and both Bullet twins, against a
// converged reference, written to DIR/accuracy.csv and plotted to DIR/accuracy.png.
#include <set>
#include <string>
#include <vector>

namespace loom::eval {

struct AccuracyOptions {
  std::vector<int> sizes{32, 64};          // nodes per side of the 1 m square
  std::string out = "out/bench_accuracy";  // owned through its manifest (OutputFolder.h)
  bool out_given = false;                  // --out named it (the default may not hold a link on its way)
  bool overwrite = false;                  // write into a non-empty folder Loom did not write
  bool quick = false;                      // tiny run for tests: N=8, 0.25 s, one configuration per method
  double duration = 0.25;                  // s of simulated time (60 Hz frames; docs/benchmarks.md)
  double perturbation = 1e-3;              // m, out-of-plane start bump (AccuracyBench.cpp, make_scene)
  std::vector<int> threads{1, 2};          // thread counts for the Loom solvers (Bullet runs single-threaded)
  std::set<std::string> methods;  // empty: all; else solver names and/or bullet_classic, bullet_deformable
  std::string configs;            // empty: all; else only Loom configurations whose label contains it
  int repeats = 1;                // runs of each Loom row (thread counts interleaved); the fastest is kept
};

// Returns the process exit code: 0 ok, 1 I/O error. The options are checked by the command line
// (apps/loom/BenchCommand.cpp): sizes and thread counts each once, a duration of whole 1/60 s frames.
int bench_accuracy(const AccuracyOptions& options);

}  // namespace loom::eval
