#include "RealtimeBench.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "BenchCommand.h"
#include "CliValue.h"
#include "loom/bullet/BodyCrossings.h"
#include "loom/bullet/Compare.h"
#include "loom/cloth/Error.h"
#include "loom/collision/MultiClothCensus.h"
#include "loom/eval/AccuracyPlot.h"
#include "loom/eval/CsvNumber.h"
#include "loom/eval/OutputFolder.h"
#include "loom/scene/Scene.h"
#include "loom/scene/SceneLimits.h"
#include "loom/scene/ScenePipeline.h"
#ifdef LOOM_HAVE_CHARACTER_COMPARE
#include "CompareCharacter.h"
#include "loom/bullet/CharacterCompare.h"
#include "loom/cloth/OutputFile.h"
#endif

namespace loom::app {

using eval::plot_accuracy;
using eval::PlotPoint;

namespace {

using cloth::Vec3;
using cloth::Vec3s;

struct Run {
  std::vector<Vec3s> frames;  // m, every cloth's vertices, concatenated, per frame
  double ms = 0.0;            // pipeline ms per frame (FrameStats::total_ms), the fastest of the repeats
  double max_strain = 0.0;    // 1
  double depth = 0.0;         // m, deepest vertex inside a collider at a frame end
  bool finite = true;
};

struct Row {
  std::string system;
  double ms = 0.0, rms = NAN, depth = 0.0, strain = 0.0;
  bool finite = true;
  int through = 0;  // bodies whose centre met the cloth (bullet::BodyCrossings); Bullet-world rows only
};

// The perturbation that fixes the flat sheet's buckling direction (as `loom bench accuracy`):
// y += A sin(pi u) sin(pi v / 2), zero at the pinned edge.
void perturb_sheet(cloth::Simulation& sim, int n) {
  constexpr double kAmplitude = 0.001, kPi = 3.14159265358979323846;  // m
  cloth::ClothState& s = sim.cloths()[0]->state();
  for (int iv = 0; iv < n; ++iv)
    for (int iu = 0; iu < n; ++iu) {
      const double u = iu / double(n - 1), v = iv / double(n - 1);
      s.x[iv * n + iu].y() += kAmplitude * std::sin(kPi * u) * std::sin(0.5 * kPi * v);
    }
  s.x_prev = s.x;
}

Run run(const scene::Scene& sc, int frames, int sheet_n, int repeats) {
  Run best;
  for (int r = 0; r < repeats; ++r) {
    Run out;
    const std::unique_ptr<scene::ScenePipeline> pipeline = scene::build_pipeline(sc);
    cloth::Simulation* sim = &pipeline->simulation();
    const collision::ColliderSetPtr& colliders = pipeline->colliders();
    if (sheet_n > 0) perturb_sheet(*sim, sheet_n);
    double ms = 0.0;
    for (int f = 0; f < frames; ++f) {
      const cloth::FrameStats st = sim->step_frame();
      if (!st.finite) {
        out.finite = false;
        break;
      }
      ms += st.total_ms;
      out.max_strain = std::max(out.max_strain, st.max_strain);
      Vec3s all;
      std::vector<collision::CensusInput> in;
      for (const auto& c : sim->cloths()) {
        all.insert(all.end(), c->state().x.begin(), c->state().x.end());
        in.push_back({&c->mesh(), &c->state().x});
      }
      if (colliders && !colliders->empty())
        out.depth = std::max(out.depth, collision::max_penetration(in, *colliders));
      out.frames.push_back(std::move(all));
    }
    out.ms = out.frames.empty() ? 0.0 : ms / out.frames.size();
    if (r == 0 || out.ms < best.ms) best = std::move(out);
  }
  return best;
}

// RMS over every frame and vertex of the distance to the reference (NaN when a run stopped early).
double rms(const Run& a, const Run& ref) {
  if (!a.finite || a.frames.size() != ref.frames.size()) return NAN;
  double sum = 0.0;
  long count = 0;
  for (size_t f = 0; f < a.frames.size(); ++f)
    for (size_t i = 0; i < a.frames[f].size(); ++i, ++count)
      sum += (a.frames[f][i] - ref.frames[f][i]).squaredNorm();
  return count ? std::sqrt(sum / count) : NAN;
}

// A Bullet-world run (bullet::run_loom_in_bullet or Bullet classic's twin): cloth 0 per frame, time per
// frame of the whole world step (cloth + Bullet, as `loom compare`), bodies through the cloth.
struct WorldRun {
  Run run;
  int through = 0;
};

WorldRun world_run(const scene::Scene& sc, const bullet::BulletSceneOptions& options, bool twin, int frames,
                   int repeats) {
  WorldRun best;
  for (int r = 0; r < repeats; ++r) {
    WorldRun out;
    cloth::Simulation start(sc.setup);  // the mesh (and the start state) of cloth 0
    std::vector<char> modes;
    for (const collision::RigidBodySpec& b : sc.bodies)
      modes.push_back(b.attachments.empty() ? bullet::BodyCrossings::kAlways : bullet::BodyCrossings::kSkip);
    std::unique_ptr<bullet::BodyCrossings> crossings;
    bullet::CompareInput in;
    in.setup = sc.setup;
    in.bodies = sc.bodies;
    in.frames = frames;
    in.options = options;
    in.on_frame = [&](const bullet::FrameSample& s) {
      if (s.frame == 0) {
        crossings = std::make_unique<bullet::BodyCrossings>(
            std::vector<const cloth::ClothMesh*>{&start.cloths()[0]->mesh()}, std::vector<Vec3s>{*s.x},
            s.centres, modes);
        return;
      }
      crossings->update({*s.x}, s.centres);
      out.run.frames.push_back(*s.x);
    };
    const bullet::SystemMetrics m =
        twin ? bullet::run_bullet_twin(in, bullet::TwinKind::kClassic) : bullet::run_loom_in_bullet(in);
    out.run.ms = m.ms_per_frame;
    out.run.max_strain = m.max_strain;
    out.run.depth = m.max_penetration;
    out.run.finite = !m.diverged && static_cast<int>(out.run.frames.size()) == frames;
    out.through = crossings ? crossings->bodies_through() : 0;
    if (r == 0 || out.run.ms < best.run.ms) best = std::move(out);
  }
  return best;
}

scene::Scene with(const std::string& path, const std::vector<std::string>& sets) {
  return scene::load_scene(path, sets);
}

// `bodies`: the CSV gets a bodies_through column (the Bullet-world scene).
void write(eval::OutputFolder& folder, const std::string& name, const std::string& title,
           const std::vector<Row>& rows, bool bodies = false) {
  OutputFile csv(folder.claim(name + ".csv"));
  csv << "system,ms_per_frame,rms_error_m,max_penetration_m,max_strain,finite"
      << (bodies ? ",bodies_through\n" : "\n");
  std::vector<PlotPoint> points;
  for (const Row& r : rows) {
    // A figure a run has not (no reference error for Bullet, a stopped run's) is an empty field, never nan.
    csv << r.system << ',' << eval::csv_number(r.ms) << ',' << eval::csv_number(r.rms) << ','
        << eval::csv_number(r.depth) << ',' << eval::csv_number(r.strain) << ',' << (r.finite ? 1 : 0);
    if (bodies) csv << "," << r.through;
    csv << "\n";
    auto shown = [](double v) { return std::isfinite(v) ? eval::csv_number(v) : std::string("-"); };
    std::printf("%-30s %10s ms %12s m rms %12s m deep %10s strain", r.system.c_str(), shown(r.ms).c_str(),
                shown(r.rms).c_str(), shown(r.depth).c_str(), shown(r.strain).c_str());
    if (bodies) std::printf(" %3d through", r.through);
    std::printf("%s\n", r.finite ? "" : "  (stopped)");
    if (std::isfinite(r.rms) && r.rms > 0.0) points.push_back({r.system, r.ms, r.rms});
  }
  plot_accuracy(folder, points, title, name);
}

const char* kUsage =
    "Usage: loom bench realtime [--out DIR] [--overwrite] [--seconds S] [--sheet N] [--toy N] [--repeats R]\n"
    "                           [--scenes LIST] [--quick]\n"
    "\n"
    "Every quality tier (realtime, balanced, reference) and Bullet classic's twin of three scenes, as time\n"
    "per frame (1 thread, fastest of R runs) against the error from a converged reference run of the same\n"
    "scene (RMS vertex distance over all frames), with the deepest penetration into a collider or body, the\n"
    "max strain and, in the Bullet world, the bodies whose centre met the cloth:\n"
    "  character_layers (scenes/character_layers_reference.json's garments and motion): reference = that\n"
    "    variant at twice its substeps; the pipeline's own timing (the twin: its wall time per frame).\n"
    "  toy_box (scenes/toy_box.json, N x N cloth): the bridge's coupled tier (realtime, balanced) and its\n"
    "    setup tier (reference: implicit Euler at the 1/240 s Bullet step); reference = the setup tier at\n"
    "    16 implicit steps per frame, strain limit 10 % with 32 iterations, checked by halving its step "
    "(the\n"
    "    row loom:converged_half_step); time = the whole world step, cloth and Bullet, as loom compare.\n"
    "  the hanging sheet (1 m cotton, 0.2 kg, two corners pinned, N x N nodes): reference = implicit Euler\n"
    "    at 64 substeps; the pipeline's own timing.\n"
    "Writes DIR/character_realtime.csv, DIR/toy_box_realtime.csv (with bodies_through), "
    "DIR/sheet_realtime.csv\n"
    "and a PNG of each (RMS error against ms per frame).\n"
    "\n"
    "Options:\n"
    "  --out DIR      output folder (default out/bench_realtime), owned through DIR/.loom-manifest\n"
    "  --overwrite    write into a non-empty folder Loom did not write (files of its names replaced)\n"
    "  --seconds S    simulated seconds of each run, whole 1/60 s frames (default 2; at least one frame;\n"
    "                 another value runs the nearest whole frames and says so; chaotic motion makes long "
    "runs\n"
    "                 diverge from any reference)\n"
    "  --sheet N      nodes per side of the sheet (default 64)\n"
    "  --toy N        nodes per side of the toy box's cloth (default 33)\n"
    "  --scenes LIST  only these of character,toy_box,sheet (default: all three)\n"
    "  --repeats R    runs per point, the fastest kept (default 1)\n"
    "  --quick        tiny run for tests: 0.1 s, sheet N = 12, toy box N = 17\n";

}  // namespace

int bench_realtime(int argc, char** argv) {
  std::string out = "out/bench_realtime";
  double seconds = 2.0;
  int sheet_n = 64, toy_n = 33, repeats = 1;
  std::set<std::string> only = {"character", "toy_box", "sheet"};
  bool overwrite = false, out_given = false, seconds_given = false, quick = false;
  bool sheet_given = false, toy_given = false;
  CliArgs args(argc, argv, 3, "bench realtime");
  while (args.next()) {
    const std::string a = args.arg();
    if (args.operand()) {
      args.fail(a, "bench realtime takes no operand");
    } else if (a == "-h" || a == "--help") {
      std::cout << kUsage;
      return 0;
    } else if (a == "--out") {
      out = cli_path(a, args.value());
      out_given = true;
    } else if (a == "--overwrite") {
      overwrite = true;
    } else if (a == "--seconds") {
      seconds = cli_number(a, args.value(), 0.0, 60.0);
      seconds_given = true;
    } else if (a == "--sheet") {
      sheet_n = static_cast<int>(cli_integer(a, args.value(), 3, 512));
      sheet_given = true;
    } else if (a == "--scenes") {
      only.clear();
      for (const std::string& name : cli_list(a, args.value())) {
        if (name != "character" && name != "toy_box" && name != "sheet")
          cli_refuse(a, name, "character, toy_box or sheet");
        only.insert(name);
      }
    } else if (a == "--toy") {
      toy_n = static_cast<int>(cli_integer(a, args.value(), 3, 256));
      toy_given = true;
    } else if (a == "--repeats") {
      repeats = static_cast<int>(cli_integer(a, args.value(), 1, 100));
    } else if (a == "--quick") {
      quick = true;
    } else {
      args.unknown();
    }
  }
  // --quick sets what was not given (as bench accuracy's --quick does), in any order of the options.
  if (quick) {
    if (!seconds_given) seconds = 0.1;
    if (!sheet_given) sheet_n = 12;
    if (!toy_given) toy_n = 17;
  }
  seconds = whole_frames("--seconds", seconds);
  std::vector<std::string> writes;
  for (const char* name : {"character_realtime", "toy_box_realtime", "sheet_realtime"})
    for (const char* ext : {".png", ".dat", ".gp", ".csv"}) writes.push_back(std::string(name) + ext);
  if (!out_given) eval::refuse_linked_default(out, "--out");
  const char* env = std::getenv("LOOM_SCENES");
  // An empty LOOM_SCENES (an unset shell variable exported) is unset: never "/" or the working directory.
  const std::string scenes =
      (env && *env ? std::string(env) : std::string(LOOM_SOURCE_DIR) + "/scenes") + "/";
  // The scene files the selected benchmarks read and every file they read (meshes, clips): one that is a
  // file the benchmark writes (or an earlier run listed) is refused before anything runs.
  std::vector<std::string> inputs;
  for (const auto& [bench, file] :
       {std::pair<const char*, const char*>{"character", "character_layers_reference.json"},
        {"toy_box", "toy_box.json"}}) {
    if (!only.count(bench)) continue;
    const scene::Scene sc = scene::load_scene(scenes + file);
    // What each benchmark runs (a character and its Bullet twin; a Bullet world and Bullet classic's twin)
    // must be in the scene it reads, and what the twins would not see must not be.
    if (std::string(bench) == "character" && !sc.character)
      throw loom::Error(scenes + file, "character", "the character benchmark needs a scene with a character");
    if (std::string(bench) == "toy_box" && sc.bodies.empty())
      throw loom::Error(scenes + file, "bodies",
                        "the toy-box benchmark needs a scene with rigid bodies (a Bullet world)");
    if (!sc.colliders.empty())
      throw loom::Error(scenes + file, "colliders",
                        "the benchmark's Bullet twin does not see scene colliders, so its rows would compare "
                        "different problems");
    inputs.push_back(scenes + file);
    inputs.insert(inputs.end(), sc.inputs.begin(), sc.inputs.end());
  }
  const int frames = static_cast<int>(std::lround(seconds * 60.0));  // whole frames (whole_frames)
  // What the sheet and toy-box runs hold, before the folder is claimed: each simulation
  // (scene::kBytesPerVertex a vertex) and every frame of the reference, the best and the current run (24
  // bytes a vertex and frame).
  for (const auto& [bench, option, n] :
       {std::tuple<const char*, const char*, int>{"sheet", "--sheet", sheet_n},
        {"toy_box", "--toy", toy_n}}) {
    if (!only.count(bench)) continue;
    const double vertices = double(n + 1) * double(n + 1);
    scene::check_memory("", option, vertices * (double(scene::kBytesPerVertex) + 3.0 * 24.0 * (frames + 1)),
                        std::string(option) + " " + std::to_string(n) + " over " + std::to_string(frames) +
                            " frames (three runs' frames kept for the errors) needs",
                        "lower " + std::string(option) + " or --seconds");
  }
  eval::OutputFolder folder(out, "--out", overwrite, false, writes, inputs);
  const std::vector<std::string> tiers = {"realtime", "balanced", "reference"};

  // The character: tiers on the reference variant's garments and motion; the reference tier is that file.
  if (only.count("character")) {
    const std::string ref_path = scenes + "character_layers_reference.json";
    const int ref_substeps = scene::load_scene(ref_path).setup.substeps;
    const Run ref =
        run(with(ref_path, {"solver.substeps=" + std::to_string(2 * ref_substeps)}), frames, 0, 1);
    std::vector<Row> rows;
    for (const std::string& t : tiers) {
      // realtime / balanced: the tier's own solver (the reference variant names implicit Euler explicitly).
      const std::vector<std::string> sets = t == "reference"
                                                ? std::vector<std::string>{}
                                                : std::vector<std::string>{"quality=" + t, "solver={}"};
      const scene::Scene sc = with(ref_path, sets);
      const Run r = run(sc, frames, 0, repeats);
      rows.push_back({"loom:" + t, r.ms, rms(r, ref), r.depth, r.max_strain, r.finite});
    }
#ifdef LOOM_HAVE_CHARACTER_COMPARE
    {
      const scene::Scene sc = with(ref_path, {});
      bullet::CharacterCompareInput in;
      in.setup = sc.setup;
      in.frames = frames;
      in.thickness = sc.setup.cloths.empty() ? 0.001 : sc.setup.cloths[0].material.thickness;
      in.bodies = character_bodies(sc.character);
      Run twin;  // every garment's vertices per frame, concatenated as in `run`
      in.on_frame = [&](int, const std::vector<const Vec3s*>& x) {
        Vec3s all;
        for (const Vec3s* g : x) all.insert(all.end(), g->begin(), g->end());
        twin.frames.push_back(std::move(all));
      };
      const bullet::CharacterMetrics m = bullet::run_bullet_character(in);
      twin.finite = !m.m.diverged;
      rows.push_back({"bullet_classic", m.m.ms_per_frame, rms(twin, ref), m.m.max_penetration, m.m.max_strain,
                      !m.m.diverged});
    }
#endif
    std::printf("# character_layers, %d frames, 1 thread\n", frames);
    write(folder, "character_realtime", "character_layers: RMS error vs time per frame", rows);
  }
  // The Bullet-world scene: every tier of the bridge and Bullet classic's twin, against a converged run of
  // the setup tier (implicit Euler at 16 steps per frame, strain limit 10 % with 32 iterations), checked by
  // halving its step.
  if (only.count("toy_box")) {
    const std::string path = scenes + "toy_box.json";
    const std::string nodes =
        "cloths.0.mesh.nodes=[" + std::to_string(toy_n) + "," + std::to_string(toy_n) + "]";
    auto setup_tier = [&](int steps, int iterations) {
      return with(path, {nodes, "quality=reference",
                         R"(solver={"method": "implicit_euler", "substeps": )" + std::to_string(steps) + "}",
                         "constraints.strain_limit.iterations=" + std::to_string(iterations)});
    };
    const scene::Scene ref_scene = setup_tier(16, 32);
    const WorldRun ref = world_run(ref_scene, scene::bullet_scene_options(ref_scene), false, frames, 1);
    const scene::Scene check_scene = setup_tier(8, 32);
    const WorldRun check = world_run(check_scene, scene::bullet_scene_options(check_scene), false, frames, 1);
    std::vector<Row> rows;
    auto row = [&](const std::string& system, const WorldRun& w) {
      rows.push_back(
          {system, w.run.ms, rms(w.run, ref.run), w.run.depth, w.run.max_strain, w.run.finite, w.through});
    };
    for (const std::string& t : tiers) {
      // reference: the setup tier with the scene's former solver, implicit Euler at the Bullet step.
      const scene::Scene sc = t == "reference" ? setup_tier(4, 8) : with(path, {nodes, "quality=" + t});
      row("loom:" + t, world_run(sc, scene::bullet_scene_options(sc), false, frames, repeats));
    }
    row("bullet_classic", world_run(with(path, {nodes}), {}, true, frames, repeats));
    row("loom:converged_half_step", check);  // the reference at half its steps: how far from converged
    rows.push_back(
        {"loom:converged", ref.run.ms, 0.0, ref.run.depth, ref.run.max_strain, ref.run.finite, ref.through});
    std::printf("# toy_box %dx%d, %d frames, 1 thread (ms: cloth and Bullet world)\n", toy_n, toy_n, frames);
    write(folder, "toy_box_realtime", "toy_box: RMS error vs time per frame", rows, true);
  }
  // The hanging sheet: JSON per tier, the same start bump.
  if (only.count("sheet")) {
    const std::string text = R"({"duration": 1, "fps": 60,
      "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [1, 1], "nodes": [@N, @N], "plane": "xz",
                  "origin": [-0.5, 1.5, -0.5]}, "material": {"preset": "cotton"}, "mass": 0.2,
                  "pins": [{"grid": [0, 0]}, {"grid": [-1, 0]}]}]})";
    std::string s = text;
    for (size_t p; (p = s.find("@N")) != std::string::npos;) s.replace(p, 2, std::to_string(sheet_n));
    const nlohmann::json base = nlohmann::json::parse(s);
    auto sheet = [&](const nlohmann::json& extra) {
      nlohmann::json root = base;
      for (auto it = extra.begin(); it != extra.end(); ++it) root[it.key()] = it.value();
      return scene::parse_scene(root, "sheet.json");
    };
    const Run ref =
        run(sheet({{"solver", {{"method", "implicit_euler"}, {"substeps", 64}}}}), frames, sheet_n, 1);
    std::vector<Row> rows;
    for (const std::string& t : tiers) {
      nlohmann::json extra = {{"quality", t}};
      if (t == "reference") extra["solver"] = {{"method", "implicit_euler"}, {"substeps", 4}};
      const Run r = run(sheet(extra), frames, sheet_n, repeats);
      rows.push_back({"loom:" + t, r.ms, rms(r, ref), r.depth, r.max_strain, r.finite});
    }
    // More points of the real-time solver: substeps at one iteration.
    for (int sub : {8, 16, 24, 32, 48}) {
      const Run r =
          run(sheet({{"quality", "realtime"}, {"solver", {{"substeps", sub}}}}), frames, sheet_n, repeats);
      rows.push_back({"loom:fast_xpbd substeps=" + std::to_string(sub), r.ms, rms(r, ref), r.depth,
                      r.max_strain, r.finite});
    }
    {  // Bullet classic's twin of the sheet (1/240 s steps, as `loom compare`), from the same start bump
      const scene::Scene sc = sheet({{"solver", {{"method", "implicit_euler"}, {"substeps", 4}}}});
      bullet::CompareInput in;
      in.setup = sc.setup;
      in.frames = frames;
      in.prepare = [&](cloth::Simulation& sim) { perturb_sheet(sim, sheet_n); };
      Run best;
      for (int r = 0; r < repeats; ++r) {
        Run twin;
        in.on_frame = [&](const bullet::FrameSample& f) {
          if (f.frame > 0) twin.frames.push_back(*f.x);
        };
        const bullet::SystemMetrics m = bullet::run_bullet_twin(in, bullet::TwinKind::kClassic);
        twin.ms = m.ms_per_frame;
        twin.max_strain = m.max_strain;
        twin.finite = !m.diverged;
        if (r == 0 || twin.ms < best.ms) best = std::move(twin);
      }
      rows.push_back({"bullet_classic", best.ms, rms(best, ref), 0.0, best.max_strain, best.finite});
    }
    std::printf("# hanging sheet N=%d, %d frames, 1 thread\n", sheet_n, frames);
    write(folder, "sheet_realtime", "hanging sheet: RMS error vs time per frame", rows);
  }
  return 0;
}

}  // namespace loom::app
