// `loom bench BENCHMARK [options]`: the command lines of `loom bench accuracy` (AccuracyBench.h) and the
// dispatch to `loom bench realtime` (RealtimeBench.h).
#include "BenchCommand.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "CliValue.h"
#include "loom/cloth/Solver.h"
#include "loom/eval/AccuracyBench.h"
#ifdef LOOM_HAVE_BENCH_REALTIME
#include "RealtimeBench.h"
#endif

namespace loom::app {

namespace {

// clang-format off
const char* kBenchUsage =
    "Usage: loom bench accuracy [--sizes 32,64,128] [--out DIR] [--quick] [--duration S] [--threads 1,2]\n"
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
    "  --out DIR       output folder (default out/bench_accuracy), owned through DIR/.loom-manifest\n"
    "  --overwrite     write into a non-empty folder Loom did not write (files of its names replaced)\n"
    "  --quick         tiny run for tests: N=8, 0.25 s, one configuration per method\n"
    "  --duration S    simulated seconds, whole 1/60 s frames (default 0.25; at least one frame; another\n"
    "                  value runs the nearest whole frames and says so; longer runs lose a converged reference)\n"
    "  --threads LIST  thread counts for Loom's solvers (default 1,2)\n"
    "  --perturbation M  amplitude of the start bump that fixes the buckling direction (default 0.001 m)\n"
    "  --methods LIST  only these solvers / bullet_classic / bullet_deformable (default: all)\n"
    "  --configs TEXT  only the Loom configurations whose label contains TEXT, e.g. 'substeps=1 cg_tolerance=0.02'\n"
    "  --repeats R     run each Loom row R times, thread counts interleaved, and keep the fastest (default 1;\n"
    "                  for thread ratios on a shared machine); a repeat with other results is reported\n";
// clang-format on

const char* kBenchesUsage =
    "Usage: loom bench BENCHMARK [options]   (the benchmark first, then its options)\n"
    "  loom bench accuracy [options]   accuracy against time per frame, Loom solvers and Bullet (--help)\n"
    "  loom bench realtime [options]   quality tiers and Bullet classic on three scenes (--help)\n";

// Whole numbers in [lo, hi], comma-separated, each once (cli_list).
std::vector<int> int_list(const std::string& flag, const std::string& text, int lo, int hi) {
  std::vector<int> out;
  for (const std::string& item : cli_list(flag, text)) {
    if (!cli_whole_text(item, false) || item.size() > 9 || std::stol(item) < lo || std::stol(item) > hi)
      cli_refuse(flag, text,
                 "a comma-separated list of whole numbers in [" + std::to_string(lo) + ", " +
                     std::to_string(hi) + "]");
    out.push_back(static_cast<int>(std::stol(item)));
  }
  return out;
}

int bench_accuracy_main(int argc, char** argv) {
  eval::AccuracyOptions o;
  bool sizes_given = false, duration_given = false;
  CliArgs args(argc, argv, 3, "bench accuracy");
  while (args.next()) {
    const std::string a = args.arg();
    if (args.operand()) {
      std::fprintf(stderr, "loom: error: bench accuracy takes no operand, got '%s' (see loom bench --help)\n",
                   show_value(a).c_str());
      return 2;
    } else if (a == "-h" || a == "--help") {
      std::cout << kBenchUsage;
      return 0;
    } else if (a == "--sizes") {
      o.sizes = int_list(a, args.value(), 3, 4096);
      sizes_given = true;
    } else if (a == "--threads") {
      o.threads = int_list(a, args.value(), 1, 4096);
      // Threads beyond the machine's only queue on its cores (and thousands exhaust the OpenMP runtime):
      // each count is capped at the hardware threads, as loom run does, and a count met twice runs once.
      const int hardware = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
      std::vector<int> capped;
      for (int t : o.threads) {
        if (t > hardware)
          std::cerr << "loom: warning: --threads " << t << " capped at the " << hardware
                    << " hardware threads of this machine\n";
        if (std::find(capped.begin(), capped.end(), std::min(t, hardware)) == capped.end())
          capped.push_back(std::min(t, hardware));
      }
      o.threads = capped;
    } else if (a == "--methods") {
      const std::vector<std::string> methods = cli_list(a, args.value());
      // An unknown name would select nothing and pass with an empty table.
      std::vector<std::string> known = cloth::solver_names();
      for (const char* extra : {"bullet_classic", "bullet_deformable", "hybrid"}) known.push_back(extra);
      for (const std::string& m : methods)
        if (std::find(known.begin(), known.end(), m) == known.end()) {
          std::string list;
          for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
          args.fail(a, "unknown method '" + show_value(m) + "' (known: " + list + ")");
        }
      o.methods.insert(methods.begin(), methods.end());
    } else if (a == "--configs") {
      o.configs = args.value();
      if (o.configs.empty()) args.fail(a, "is an empty string (an unset variable?)");
    } else if (a == "--out") {
      o.out = cli_path(a, args.value());
      o.out_given = true;
    } else if (a == "--duration") {
      o.duration = cli_number(a, args.value(), 0.0, 60.0);
      duration_given = true;
    } else if (a == "--perturbation") {
      o.perturbation = cli_number(a, args.value(), 0.0, 0.1);
    } else if (a == "--repeats") {
      o.repeats = static_cast<int>(cli_integer(a, args.value(), 1, 4096));
    } else if (a == "--overwrite") {
      o.overwrite = true;
    } else if (a == "--quick") {
      o.quick = true;
    } else {
      args.unknown();
    }
  }
  if (o.quick) {
    if (!sizes_given) o.sizes = {8};
    if (!duration_given) o.duration = 0.25;
  }
  o.duration = whole_frames("--duration", o.duration);
  return eval::bench_accuracy(o);
}

}  // namespace

double whole_frames(const std::string& flag, double seconds) {
  constexpr double kFps = 60.0;
  const double frames = seconds * kFps;
  const double whole = std::round(frames);
  // A decimal seconds value of a whole frame count (0.0166667 for one frame) is within 1e-4 frames of it.
  if (frames < 1.0 - 1e-4)
    cli_error(flag, cli_show(seconds) + " s is shorter than one frame of 1/60 s (" + cli_show(frames) +
                        " frames): give at least 0.0166667");
  if (std::abs(frames - whole) > 1e-4)
    std::fprintf(stderr,
                 "loom: note: %s %s s is %s frames of 1/60 s: runs %.0f whole frames (%s s), as the tables "
                 "say\n",
                 flag.c_str(), cli_show(seconds).c_str(), cli_show(frames).c_str(), whole,
                 cli_show(whole / kFps).c_str());
  return whole / kFps;
}

int bench_main(int argc, char** argv) {
  const std::string bench = argc > 2 ? argv[2] : "";
  if (argc < 3 || bench == "-h" || bench == "--help") {
    std::cout << kBenchesUsage << "\n" << kBenchUsage;
    return argc < 3 ? 2 : 0;
  }
  if (bench == "accuracy") return bench_accuracy_main(argc, argv);
#ifdef LOOM_HAVE_BENCH_REALTIME
  if (bench == "realtime") return bench_realtime(argc, argv);
#endif
  if (!bench.empty() && bench[0] == '-')
    std::fprintf(stderr,
                 "loom: error: bench: name the benchmark before its options: loom bench accuracy|realtime "
                 "[options] (got the option '%s' first)\n",
                 show_value(bench).c_str());
  else
    std::fprintf(stderr, "loom: error: unknown benchmark '%s' (known: accuracy%s; see loom bench --help)\n",
                 show_value(bench).c_str(),
#ifdef LOOM_HAVE_BENCH_REALTIME
                 ", realtime"
#else
                 ""
#endif
    );
  return 2;
}

}  // namespace loom::app
