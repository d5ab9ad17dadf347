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
#include <string>
#include <vector>

#include "CliValue.h"
#include "loom/collision/MultiClothCensus.h"
#include "loom/eval/AccuracyPlot.h"
#include "loom/eval/OutputFolder.h"
#include "loom/scene/Scene.h"
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

scene::Scene with(const std::string& path, const std::vector<std::string>& sets) {
  return scene::load_scene(path, sets);
}

void write(eval::OutputFolder& folder, const std::string& name, const std::string& title,
           const std::vector<Row>& rows) {
  for (const char* ext : {".png", ".dat", ".gp"}) folder.claim(name + ext);  // the plot's files
  OutputFile csv(folder.claim(name + ".csv"));
  csv << "system,ms_per_frame,rms_error_m,max_penetration_m,max_strain,finite\n";
  std::vector<PlotPoint> points;
  for (const Row& r : rows) {
    char line[256];
    std::snprintf(line, sizeof line, "%s,%.6g,%.6g,%.6g,%.6g,%d\n", r.system.c_str(), r.ms, r.rms, r.depth,
                  r.strain, r.finite ? 1 : 0);
    csv << line;
    std::printf("%-30s %10.3f ms %12.5g m rms %12.5g m deep %10.4f strain%s\n", r.system.c_str(), r.ms, r.rms,
                r.depth, r.strain, r.finite ? "" : "  (stopped)");
    if (std::isfinite(r.rms) && r.rms > 0.0) points.push_back({r.system, r.ms, r.rms});
  }
  plot_accuracy(points, title, (folder.dir() / (name + ".png")).string());
}

const char* kUsage =
    "Usage: loom bench realtime [--out DIR] [--overwrite] [--seconds S] [--sheet N] [--repeats R] [--quick]\n"
    "\n"
    "Every quality tier (realtime, balanced, reference) of the character scene "
    "(scenes/character_layers.json)\n"
    "and of the hanging sheet (1 m cotton, 0.2 kg, two corners pinned, N x N nodes), and Bullet classic's "
    "twin\n"
    "of the character, as time per frame (1 thread, the pipeline's own timing, fastest of R runs) against "
    "the\n"
    "error from a converged reference run of the same scene: the character's reference variant at twice its\n"
    "substeps, the sheet at implicit Euler with 64 substeps. Errors: RMS vertex distance over all frames,\n"
    "deepest penetration into a collider and max strain. Writes DIR/character_realtime.csv, "
    "DIR/sheet_realtime.csv\n"
    "and a PNG of each (RMS error against ms per frame).\n"
    "\n"
    "Options:\n"
    "  --out DIR      output folder (default out/bench_realtime), owned through DIR/.loom-manifest\n"
    "  --overwrite    write into a non-empty folder Loom did not write (files of its names replaced)\n"
    "  --seconds S    simulated seconds of each run (default 2; chaotic motion makes long runs diverge from\n"
    "                 any reference)\n"
    "  --sheet N      nodes per side of the sheet (default 64)\n"
    "  --repeats R    runs per point, the fastest kept (default 1)\n"
    "  --quick        tiny run for tests: 0.1 s, N = 12\n";

}  // namespace

int bench_realtime(int argc, char** argv) {
  std::string out = "out/bench_realtime";
  double seconds = 2.0;
  int sheet_n = 64, repeats = 1;
  bool overwrite = false;
  std::set<std::string> seen;  // options that take a value, given once
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "loom: error: %s needs a value (see loom bench realtime --help)\n", a.c_str());
        std::exit(2);
      }
      cli_once(seen, a);
      return argv[++i];
    };
    if (a == "-h" || a == "--help") {
      std::cout << kUsage;
      return 0;
    } else if (a == "--out") {
      out = value();
      if (out.empty()) cli_refuse(a, out, "a folder (an unset variable?)");
    } else if (a == "--overwrite") {
      overwrite = true;
    } else if (a == "--seconds") {
      seconds = cli_number(a, value(), 0.001, 60.0);
    } else if (a == "--sheet") {
      sheet_n = static_cast<int>(cli_integer(a, value(), 3, 512));
    } else if (a == "--repeats") {
      repeats = static_cast<int>(cli_integer(a, value(), 1, 100));
    } else if (a == "--quick") {
      seconds = 0.1, sheet_n = 12;
    } else {
      std::fprintf(stderr, "loom: error: unknown option '%s' (see loom bench realtime --help)\n", a.c_str());
      return 2;
    }
  }
  std::vector<std::string> writes;
  for (const char* name : {"character_realtime", "sheet_realtime"})
    for (const char* ext : {".png", ".dat", ".gp", ".csv"}) writes.push_back(std::string(name) + ext);
  eval::OutputFolder folder(out, "--out", overwrite, false, writes);
  const int frames = std::max(1, static_cast<int>(std::lround(seconds * 60.0)));
  const char* env = std::getenv("LOOM_SCENES");
  const std::string scenes = (env ? std::string(env) : std::string(LOOM_SOURCE_DIR) + "/scenes") + "/";
  const std::vector<std::string> tiers = {"realtime", "balanced", "reference"};

  // The character: tiers on the reference variant's garments and motion; the reference tier is that file.
  {
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
      const bullet::CharacterMetrics m = bullet::run_bullet_character(in);
      rows.push_back(
          {"bullet_classic", m.m.ms_per_frame, NAN, m.m.max_penetration, m.m.max_strain, !m.m.diverged});
    }
#endif
    std::printf("# character_layers, %d frames, 1 thread\n", frames);
    write(folder, "character_realtime", "character_layers: RMS error vs time per frame", rows);
  }
  // The hanging sheet: JSON per tier, the same start bump.
  {
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
    std::printf("# hanging sheet N=%d, %d frames, 1 thread\n", sheet_n, frames);
    write(folder, "sheet_realtime", "hanging sheet: RMS error vs time per frame", rows);
  }
  return 0;
}

}  // namespace loom::app
