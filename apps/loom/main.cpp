// loom: the command-line front end. `loom --help` lists the commands.
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <new>
#include <string>

#include "BodyCommand.h"
#include "CcdEvalCommand.h"
#include "CliValue.h"
#include "FabricTestCommand.h"
#include "RunCommand.h"
#include "Terminal.h"
#include "loom/eval/FabricTests.h"
#ifdef LOOM_HAVE_BENCH_ACCURACY
#include "BenchCommand.h"
#include "CompareCommand.h"
#endif
#include "loom/cloth/Error.h"
#include "loom/cloth/Material.h"
#include "loom/cloth/Solver.h"
#include "loom/scene/SceneLimits.h"

namespace {

const char* kUsageRest =
    "  loom bench accuracy [opts]   accuracy-vs-time benchmark, Loom solvers and Bullet (loom bench --help)\n"
    "  loom bench realtime [opts]   quality tiers and Bullet classic: character, toy box, sheet (--help)\n"
    "  loom compare SCENE [--out D] a scene in Loom, Bullet classic and deformable side by side\n"
    "  loom body MESH CLIP.bvh      a body mesh fitted to a mocap skeleton, with a skinned cape\n"
    "  loom --help                  this text\n"
    "  loom run --help              the options of `run`\n"
    "\n"
    "Exit codes: 0 success, 1 bad input or I/O error, 2 bad command line, 3 simulation diverged,\n"
    "130 interrupted by Ctrl-C (resume with loom run --resume DIR).\n"
    "\n"
    "Every command reads an option's value as the next argument (--out DIR) or after '=' (--out=DIR);\n"
    "-- ends the options (a scene named -x.json: loom run -- -x.json).\n";

// The fabric tests' list comes from their one table (FabricTests.h), so it cannot drift.
std::string usage() {
  return "loom — cloth simulation for game physics\n"
         "\n"
         "Usage:\n"
         "  loom run [SCENE] [options]   run a scene (default: the default scene in scenes/)\n"
         "  loom ccd-eval FILE.csv...    evaluate the continuous collision test on CCD sample queries\n"
         "  loom fabric-test TEST [opts] virtual fabric tests: " +
         loom::eval::fabric_test_list() + "\n" + kUsageRest;
}

std::string run_usage() {
  std::string solvers, presets;
  for (const auto& s : loom::cloth::solver_names()) solvers += (solvers.empty() ? "" : ", ") + s;
  for (const auto& p : loom::cloth::material_preset_names()) presets += (presets.empty() ? "" : ", ") + p;
  return "Usage: loom run [SCENE] [--out DIR] [--frames N] [--threads N] [--profile] [--render] [--set "
         "PATH=VALUE ...]\n"
         "                [--checkpoint-every N] [--resume DIR] [--overwrite]\n"
         "\n"
         "Runs SCENE (a JSON file; default: " +
         loom::app::default_scene_path() +
         ") and writes\n"
         "  DIR/frames/frame_NNNNN.obj  every k-th frame (scene: output.every)\n"
         "  DIR/stats.csv               one row per frame: time, energies, strain, per-stage ms\n"
         "  DIR/summary.json            frames, sim_seconds, wall_seconds, ms_per_frame, stages, "
         "max_strain,\n"
         "                              mean_strain, finite (written last: its presence means the run "
         "ended)\n"
         "\n"
         "Options:\n"
         "  --out DIR          output folder (default: out/<scene name>); loom run owns it through\n"
         "                     DIR/.loom-manifest: it writes only there and deletes only files it wrote\n"
         "  --overwrite        write into a non-empty folder that loom run did not create (no manifest):\n"
         "                     files of the names it writes are replaced, nothing else is deleted\n"
         "  --frames N         number of frames to simulate (default: the scene's duration x fps)\n"
         "  --threads N        OpenMP threads for the per-element loops (default: the scene's, else 1)\n"
         "  --profile          print a table of pipeline stages: total and per-frame milliseconds, counters\n"
         "  --render           also render DIR/render/frame_NNNNN.png, DIR/render.mp4 and DIR/render.gif\n"
         "                     (offscreen, software OpenGL; scene: output.render {width, height, every, "
         "camera})\n"
         "  --checkpoint-every N  write DIR/checkpoint/checkpoint.bin every N frames (atomically; Ctrl-C "
         "also\n"
         "                     writes one, then stops at the frame boundary with valid outputs, exit 130)\n"
         "  --resume DIR       continue the run whose checkpoint is in DIR (bit-identical to not stopping)\n"
         "  --census           after every frame count intersecting triangle pairs exactly (self pairs "
         "sharing no\n"
         "                     vertex, and pairs between cloths) and the deepest vertex inside a collider;\n"
         "                     summary.json gets intersections (largest count) and max_penetration (m)\n"
         "  --set PATH=VALUE   override any scene value before it is checked, e.g.\n"
         "                     --set solver.method=verlet  --set cloths[0].material.preset=denim_11oz\n"
         "                     VALUE is read as JSON when it parses (numbers, arrays), else as a string\n"
         "  -h, --help         this text\n"
         "\n"
         "Solvers: " +
         solvers + "\nMaterial presets: " + presets + "\n";
}

// A whole number in [lo, hi] (CliValue.h: exactly the digits; the message states this range).
int parse_int(const std::string& flag, const std::string& value, long long lo, long long hi) {
  return static_cast<int>(loom::app::cli_integer(flag, value, lo, hi));
}

int run_main(int argc, char** argv) {
  loom::app::RunOptions o;
  loom::app::CliArgs args(argc, argv, 2, "run");
  while (args.next()) {
    const std::string a = args.arg();
    if (args.operand()) {
      if (!o.scene.empty()) {
        std::fprintf(stderr, "loom: error: more than one scene given ('%s', '%s')\n",
                     loom::app::printable(o.scene).c_str(), loom::app::printable(a).c_str());
        return 2;
      }
      o.scene = loom::app::cli_path("SCENE", a);
    } else if (a == "-h" || a == "--help") {
      std::cout << run_usage();
      return 0;
    } else if (a == "--out") {
      o.out = loom::app::cli_path(a, args.value());
    } else if (a == "--frames") {
      const std::string v = args.value();
      // A run of no frame is nonsense, like a duration shorter than a frame; with --resume too (a resume
      // may ask for exactly the checkpoint's frames, which is at least 1).
      if (v == "0") {
        std::fprintf(stderr,
                     "loom: error: --frames must be >= 1 (got 0): a run simulates at least one frame\n");
        return 2;
      }
      o.frames = parse_int(a, v, 1, loom::scene::kMaxFrames);
    } else if (a == "--threads") {
      o.threads = parse_int(a, args.value(), 1, loom::scene::kMaxThreads);
    } else if (a == "--checkpoint-every") {
      o.checkpoint_every = parse_int(a, args.value(), 0, loom::scene::kMaxFrames);
    } else if (a == "--resume") {
      o.resume = loom::app::cli_path(a, args.value());
    } else if (a == "--overwrite") {
      o.overwrite = true;
    } else if (a == "--profile") {
      o.profile = true;
    } else if (a == "--render") {
      o.render = true;
    } else if (a == "--census") {
      o.census = true;
    } else if (a == "--set") {
      o.sets.push_back(args.value());
    } else {
      args.unknown();
    }
  }
  // --set's own syntax is the command line's: a value without PATH= is a malformed option (exit 2); what
  // PATH and VALUE say is the scene's to check.
  for (const std::string& set : o.sets) {
    const std::size_t eq = set.find('=');
    if (eq == std::string::npos || eq == 0) {
      std::fprintf(stderr, "loom: error: --set: expected PATH=VALUE (got '%s')\n",
                   loom::app::printable(set).c_str());
      return 2;
    }
  }
  if (!o.resume.empty() && !o.scene.empty()) {
    std::fprintf(stderr,
                 "loom: error: --resume takes the scene from the checkpoint; do not also give one ('%s')\n",
                 loom::app::printable(o.scene).c_str());
    return 2;
  }
  // A resumed run is the checkpoint's run: its folder, its --set overrides and its outputs. An option that
  // would change them is refused, never dropped in silence.
  if (!o.resume.empty()) {
    // --census counts from frame 0 and the checkpoint holds no count: a resumed census would cover the
    // resumed frames only. --threads, --frames, --checkpoint-every and --profile are allowed: results are
    // the same bits for 1 and 2 threads (docs/validation.md, determinism; BadInputCli tests a resume).
    const char* clash = !o.out.empty()    ? "--out"
                        : !o.sets.empty() ? "--set"
                        : o.render        ? "--render"
                        : o.census        ? "--census"
                                          : nullptr;
    if (clash) {
      std::fprintf(
          stderr,
          "loom: error: %s: not with --resume (the run continues in its folder with the checkpoint's "
          "scene, --set overrides and outputs%s)\n",
          clash,
          std::strcmp(clash, "--census") == 0 ? "; a census counts from frame 0, the checkpoint "
                                                "holds none"
                                              : "");
      return 2;
    }
  }
  return loom::app::run_command(o);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "--help")) {
    std::cout << usage();
    return argc < 2 ? 2 : 0;
  }
  const std::string cmd = argv[1];
  try {  // the environment is part of the command line: a malformed LOOM_MEMORY_LIMIT is never ignored
    loom::scene::memory_limit_env();
  } catch (const loom::Error& e) {
    std::cerr << "loom: error: " << loom::app::printable(e.what()) << "\n";
    return 2;
  }
  try {
    if (cmd == "run") return run_main(argc, argv);
#ifdef LOOM_HAVE_BENCH_ACCURACY
    if (cmd == "bench") return loom::app::bench_main(argc, argv);
    if (cmd == "compare") return loom::app::compare_main(argc, argv);
#endif
#ifdef LOOM_HAVE_BODY
    if (cmd == "body") return loom::app::body_main(argc, argv);
#endif
    if (cmd == "ccd-eval") return loom::app::ccd_eval_main(argc, argv);
    if (cmd == "fabric-test") return loom::app::fabric_test_main(argc, argv);
  } catch (const loom::Error& e) {
    std::cerr << "loom: error: " << loom::app::printable(e.what()) << "\n";
    return 1;
  } catch (const std::bad_alloc&) {
    std::cerr << "loom: error: out of memory (the scene asks for more than this machine has)\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "loom: error: " << loom::app::printable(e.what()) << "\n";
    return 1;
  }
  std::fprintf(stderr, "loom: error: unknown command '%s' (see loom --help)\n",
               loom::app::printable(cmd).c_str());
  return 2;
}
