// loom_bench_character_clips: whole motion-capture clips, start to end, with the shipped character
// scenes, every acceptance check measured at every pipeline step by characters::ClipProbe (NaN, strain,
// vertex speed, depth inside a capsule, attachment tracking, and the exact census on layered scenes), plus
// wall ms per frame. Too long for ctest (a clip is 23-38 s of motion); tests/characters/test_clips.cpp runs
// excerpts of the same checks.
//
//   loom_bench_character_clips [--resolution M] [--threads N] [--census-every K] [--clips a.bvh,b.bvh]
//                              [--scenes character_cape,character_skirt,...] [--seconds S] [--start S]
//                              [--set key=value]...   (scene overrides, as `loom run --set`)
// Clips are looked up in tests/data/mocap/ and in Debian's assimp-testmodels (/usr/share/assimp/models/BVH/).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "loom/characters/Character.h"
#include "loom/characters/ClipProbe.h"
#include "loom/cloth/Error.h"
#include "loom/scene/Scene.h"
#include "loom/scene/ScenePipeline.h"

namespace fs = std::filesystem;

namespace {

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(item);
  return out;
}

std::string find_clip(const std::string& name) {
  for (const std::string& dir :
       {std::string(LOOM_SOURCE_DIR) + "/tests/data/mocap", std::string("/usr/share/assimp/models/BVH")})
    if (fs::exists(fs::path(dir) / name)) return (fs::path(dir) / name).string();
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  std::string resolution = "0.08";
  int threads = 1, census_every = 1;
  double seconds = 0.0;  // 0: the whole clip
  // s, clip time at t = 0: one CMU frame (1/120 s), since frame 0 of the CMU clips is a T-pose calibration
  // frame 154-177 degrees away from frame 1 (a snap no garment survives); "whole clip" = frame 1 to the end.
  double start = 1.0 / 120.0;
  std::vector<std::string> clips = {"01_01.bvh", "01_03.bvh", "Boxing_Toes.bvh"};
  std::vector<std::string> scenes = {"character_cape", "character_skirt", "character_layers",
                                     "character_shirt"};
  std::vector<std::string> extra;  // --set overrides
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--resolution")
      resolution = v;
    else if (a == "--threads")
      threads = std::atoi(v.c_str());
    else if (a == "--census-every")
      census_every = std::atoi(v.c_str());
    else if (a == "--clips")
      clips = split(v);
    else if (a == "--scenes")
      scenes = split(v);
    else if (a == "--seconds")
      seconds = std::atof(v.c_str());
    else if (a == "--start")
      start = std::atof(v.c_str());
    else if (a == "--set")
      extra.push_back(v);
    else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    }
  }
  std::printf(
      "# loom_bench_character_clips: resolution %s m, %d thread(s), census every %d step(s) (0: off)\n",
      resolution.c_str(), threads, census_every);
  std::printf(
      "# depth: deepest free vertex inside a capsule (m; the tolerance is the cloth thickness 0.001 m);"
      " att_depth: the same for attached vertices\n");
  std::printf("# t_*: clip time (s) of the worst frame/step of strain, speed, free and attached depth\n");
  std::printf("# bone/att_bone: the capsule of the deepest free / attached vertex\n");
  std::printf("%-17s %-16s %7s %6s %5s %7s %10s %10s %10s %10s %7s %9s %6s %10s %8s %8s %8s %8s %s %s\n",
              "scene", "clip", "seconds", "frames", "nan", "verts", "max_strain", "max_speed", "depth",
              "track", "census", "ms/frame", "rollb", "att_depth", "t_strain", "t_speed", "t_depth", "t_att",
              "bone", "att_bone");
  int failures = 0;
  for (const std::string& clip : clips) {
    const std::string path = find_clip(clip);
    if (path.empty()) {
      std::printf(
          "%-17s %-16s not found (tests/data/mocap, /usr/share/assimp/models/BVH: Debian "
          "assimp-testmodels)\n",
          "-", clip.c_str());
      continue;
    }
    for (const std::string& name : scenes) {
      const std::string scene_file = std::string(LOOM_SOURCE_DIR) + "/scenes/" + name + ".json";
      try {
        std::vector<std::string> sets = {"character.bvh=" + path, "character.start=" + std::to_string(start)};
        for (int g = 0; g < 2; ++g)
          sets.push_back("character.garments." + std::to_string(g) + ".resolution=" + resolution);
        sets.insert(sets.begin() + 2, extra.begin(),
                    extra.end());  // before the garment overrides (popped below)
        // The number of garments is the scene's: drop the override of a garment that does not exist.
        loom::scene::Scene probe_scene;
        try {
          probe_scene = loom::scene::load_scene(scene_file, sets);
        } catch (const loom::Error&) {
          sets.pop_back();
          probe_scene = loom::scene::load_scene(scene_file, sets);
        }
        const double duration = seconds > 0.0 ? seconds : probe_scene.character->motion.duration() - start;
        sets.push_back("duration=" + std::to_string(duration));
        loom::scene::Scene sc = loom::scene::load_scene(scene_file, sets);
        sc.setup.threads = threads;
        auto pipeline = loom::scene::build_pipeline(sc);
        loom::cloth::Simulation* sim = &pipeline->simulation();
        auto probe = std::make_unique<loom::characters::ClipProbe>(sc.character, census_every);
        const loom::characters::ClipProbe* p = probe.get();
        sim->add_stage(std::move(probe));
        int vertices = 0;
        for (const auto& c : sim->cloths()) vertices += c->state().size();
        double max_strain = 0.0, strain_time = 0.0;
        bool finite = true;
        const auto t0 = std::chrono::steady_clock::now();
        int frames = 0;
        for (; frames < sc.frames; ++frames) {
          const auto s = sim->step_frame();
          finite = finite && s.finite;
          if (!s.finite) break;
          if (s.max_strain > max_strain)
            max_strain = s.max_strain, strain_time = (frames + 1) * sc.setup.frame_dt;
        }
        const double ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() /
            std::max(frames, 1);
        const auto& f = p->figures();
        const bool nan = !finite || !f.finite;
        const auto& bones = sc.character->rig.bones();
        auto bone_name = [&](int b) { return b < 0 ? std::string("-") : bones[b].name; };
        std::printf(
            "%-17s %-16s %7.2f %6d %5s %7d %10.4f %10.3f %10.5f %10.2e %7s %9.2f %6ld %10.5f %8.2f %8.2f "
            "%8.2f %8.2f %s %s\n",
            name.c_str(), clip.c_str(), frames * sc.setup.frame_dt, frames, nan ? "yes" : "no", vertices,
            max_strain, f.max_speed, f.max_depth, f.max_track,
            census_every > 0 ? std::to_string(f.max_intersections).c_str() : "-", ms, sim->rollbacks(),
            f.max_attached_depth, start + strain_time, start + f.max_speed_time, start + f.max_depth_time,
            start + f.max_attached_depth_time, bone_name(f.max_depth_bone).c_str(),
            bone_name(f.max_attached_depth_bone).c_str());
        if (!sim->failure().empty())
          std::printf("# %s on %s stopped at frame %d: %s\n", name.c_str(), clip.c_str(), frames,
                      sim->failure().c_str());
        std::fflush(stdout);
        failures += nan || frames < sc.frames;
      } catch (const loom::Error& e) {
        std::printf("%-17s %-16s error: %s\n", name.c_str(), clip.c_str(), e.what());
        ++failures;
      }
    }
  }
  return failures ? 1 : 0;
}
