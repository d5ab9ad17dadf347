// Checkpoint and resume through `loom run`:
//   - `--checkpoint-every N` then `--resume DIR` gives the same frames (OBJ text), the same stats rows and
//   the
//     same PC2 cache as one uninterrupted run;
//   - Ctrl-C (SIGINT to a running `loom run`) stops at a frame boundary with exit 130, valid outputs
//     (summary.json "completed": false, "interrupted": true; no half-written frame) and a checkpoint that
//     resumes bit-identically;
//   - the guard: a run that cannot be rescued stops with exit 3 naming the scene, the time and the cause,
//     keeps its good frames, marks summary.json finite/completed false and writes no NaN anywhere.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include "CliRunner.h"

namespace {

namespace fs = std::filesystem;
using loom::test::slurp;

const char* kScene = R"({
  "duration": 0.5, "fps": 60,
  "solver": {"method": "bdf2", "substeps": 2},
  "effects": {"drag": {"isotropic": 0.05, "normal": 1.0, "wind": [3, 0, 1], "gust_amplitude": 0.3, "gust_frequency": 1.5}},
  "cloths": [{"name": "sheet",
              "mesh": {"type": "grid", "size": [1, 1], "nodes": [9, 9], "origin": [-0.5, 1, -0.5]},
              "material": {"preset": "cotton"}, "mass": 0.2,
              "pins": [{"grid": [0, 0]}, {"grid": [-1, 0], "path": {"times": [0, 0.3], "offsets": [[0, 0, 0], [0.05, 0.1, 0]]}}]}],
  "output": {"formats": ["obj", "pc2"]}
})";

std::string write_scene(const fs::path& dir, const std::string& text = kScene) {
  const fs::path p = dir / "scene.json";
  std::ofstream(p) << text;
  return p.string();
}

// Every frame's OBJ text, the first 7 stats columns of every row (no timings), and the PC2 bytes, hashed.
std::string fingerprint_text(const fs::path& out, int frames) {
  std::string all;
  for (int f = 0; f <= frames; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", f);
    EXPECT_TRUE(fs::exists(out / "frames" / name)) << out / "frames" / name;
    all += slurp(out / "frames" / name);
  }
  std::istringstream csv(slurp(out / "stats.csv"));
  std::string line;
  int rows = -1;
  while (std::getline(csv, line)) {
    std::string cols;
    std::istringstream ls(line);
    std::string cell;
    for (int k = 0; k < 7 && std::getline(ls, cell, ','); ++k) cols += cell + ",";
    all += cols + "\n";
    ++rows;
  }
  EXPECT_EQ(rows, frames + 1) << out;
  all += slurp(out / "pc2" / "sheet.pc2");
  return all;
}
size_t run_fingerprint(const fs::path& out, int frames) {
  return std::hash<std::string>()(fingerprint_text(out, frames));
}

TEST(Checkpoint, ResumeIsBitIdenticalToAnUninterruptedRun) {
  const fs::path dir = loom::test::test_dir();
  const std::string scene = write_scene(dir);
  const fs::path whole = dir / "whole", parts = dir / "parts";
  fs::remove_all(whole);
  fs::remove_all(parts);
  auto r = loom::test::run_loom("run " + scene + " --frames 24 --out " + whole.string());
  ASSERT_EQ(r.code, 0) << r.err;
  // Stops after 16 frames with checkpoints at 5, 10 and 15; resumed from frame 15 to 24.
  r = loom::test::run_loom("run " + scene + " --frames 16 --checkpoint-every 5 --out " + parts.string());
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(parts / "checkpoint" / "checkpoint.bin"));
  EXPECT_FALSE(fs::exists(parts / "checkpoint" / "checkpoint.bin.tmp"));
  r = loom::test::run_loom("run --resume " + parts.string() + " --frames 24");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(slurp(parts / "summary.json"));
  EXPECT_EQ(j["frames"], 24);
  EXPECT_EQ(j["resumed_from_frame"], 15);
  EXPECT_TRUE(j["completed"].get<bool>());
  const auto w = nlohmann::json::parse(slurp(whole / "summary.json"));
  EXPECT_EQ(j["max_strain"].get<double>(), w["max_strain"].get<double>());
  EXPECT_EQ(j["mean_strain"].get<double>(), w["mean_strain"].get<double>());
  EXPECT_EQ(run_fingerprint(parts, 24), run_fingerprint(whole, 24));
}

TEST(Checkpoint, ResumeWithCharacterCollidersAndSelfCollisionIsBitIdentical) {
  // The shipped cape scene (capsule rig from a mocap clip, swept body collision, tethers) made small, with
  // self-collision on: the rig's, the colliders' and the contact stages' state go through the checkpoint.
  const fs::path dir = loom::test::test_dir();
  const fs::path whole = dir / "whole", parts = dir / "parts";
  fs::remove_all(whole);
  fs::remove_all(parts);
  const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/character_cape_reference.json";
  const std::string set =
      " --set 'character.garments[0].resolution=0.1' --set 'collision={\"self\":true}' --set output.every=1 ";
  auto r = loom::test::run_loom("run " + scene + set + "--frames 10 --out " + whole.string());
  if (r.err.find("this build has no loom::characters") != std::string::npos)
    GTEST_SKIP() << "no loom::characters";
  ASSERT_EQ(r.code, 0) << r.err;
  r = loom::test::run_loom("run " + scene + set + "--frames 7 --checkpoint-every 3 --out " + parts.string());
  ASSERT_EQ(r.code, 0) << r.err;
  r = loom::test::run_loom("run --resume " + parts.string() + " --frames 10");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(slurp(parts / "summary.json"))["resumed_from_frame"], 6);
  for (int f = 0; f <= 10; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", f);
    ASSERT_TRUE(fs::exists(whole / "frames" / name)) << name;
    EXPECT_EQ(slurp(parts / "frames" / name), slurp(whole / "frames" / name)) << name;
  }
}

TEST(Checkpoint, ResumeRefusesAChangedScene) {
  const fs::path dir = loom::test::test_dir();
  const std::string scene = write_scene(dir);
  const fs::path out = dir / "out";
  fs::remove_all(out);
  ASSERT_EQ(
      loom::test::run_loom("run " + scene + " --frames 6 --checkpoint-every 2 --out " + out.string()).code,
      0);
  std::string changed = kScene;
  changed.replace(changed.find("\"mass\": 0.2"), 11, "\"mass\": 0.3");
  write_scene(dir, changed);
  const auto r = loom::test::run_loom("run --resume " + out.string());
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(scene), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("changed since the checkpoint"), std::string::npos) << r.err;
}

// The OBJ frames written before the checkpoint are part of the run: one removed, cut or edited since is
// refused by name (a resumed run would otherwise end "completed" with a hole), and the folder is left as it
// was.
TEST(Checkpoint, ResumeRefusesFramesRemovedOrChangedSinceTheCheckpoint) {
  const fs::path dir = loom::test::test_dir();
  const std::string scene = write_scene(dir);
  const fs::path out = dir / "out";
  auto fresh = [&] {
    fs::remove_all(out);
    ASSERT_EQ(
        loom::test::run_loom("run " + scene + " --frames 10 --checkpoint-every 5 --out " + out.string()).code,
        0);
  };
  fresh();
  fs::remove(out / "frames" / "frame_00003.obj");
  auto r = loom::test::run_loom("run --resume " + out.string() + " --frames 15");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find((out / "frames" / "frame_00003.obj").string() + ": --resume: is missing"),
            std::string::npos)
      << r.err;
  EXPECT_TRUE(fs::exists(out / "summary.json")) << "the refused resume changed the folder";
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00011.obj"));

  fresh();
  std::ofstream(out / "frames" / "frame_00002.obj", std::ios::app) << "v 0 0 0\n";
  r = loom::test::run_loom("run --resume " + out.string() + " --frames 15");
  EXPECT_EQ(r.code, 1) << r.err;
  // The changed file is named (the checkpoint holds each frame file's own hash).
  EXPECT_NE(r.err.find((out / "frames" / "frame_00002.obj").string() +
                       ": --resume: this frame file, written before the checkpoint at frame 5, was changed"),
            std::string::npos)
      << r.err;

  fresh();  // untouched: resumes
  r = loom::test::run_loom("run --resume " + out.string() + " --frames 15");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_00015.obj"));
  // ... and a second resume checks the frames the first one added as well.
  r = loom::test::run_loom("run " + scene + " --frames 12 --checkpoint-every 4 --out " + out.string() +
                           " --overwrite");
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_EQ(loom::test::run_loom("run --resume " + out.string() + " --frames 16").code, 0);
  std::ofstream(out / "frames" / "frame_00010.obj", std::ios::app)
      << "# edited\n";  // before its checkpoint at 12
  r = loom::test::run_loom("run --resume " + out.string() + " --frames 20");
  EXPECT_EQ(r.code, 1) << r.err;
}

// SIGTERM (kill, timeout, a CI cancelling) and SIGHUP (the terminal closed) stop a run like Ctrl-C: the
// frames done keep their stats, a checkpoint resumes it, exit 128 + the signal. Under nohup (SIGHUP ignored
// by the parent) a SIGHUP changes nothing.
TEST(Checkpoint, TermAndHangupStopLikeCtrlCAndNohupKeepsHangupIgnored) {
  const fs::path dir = loom::test::test_dir();
  std::string text = kScene;
  text.replace(text.find("\"substeps\": 2"), 13, "\"substeps\": 40");
  const std::string scene = write_scene(dir, text);
  auto start = [&](const fs::path& out, bool ignore_hup) {
    const pid_t pid = fork();
    if (pid == 0) {
      const std::string log = (dir / "child.txt").string();
      if (!freopen(log.c_str(), "w", stdout) || !freopen(log.c_str(), "a", stderr)) _exit(99);
      if (ignore_hup) std::signal(SIGHUP, SIG_IGN);
      execl(LOOM_BINARY, LOOM_BINARY, "run", scene.c_str(), "--frames", "99999", "--out",
            out.string().c_str(), (char*)nullptr);
      _exit(98);
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!fs::exists(out / "frames" / "frame_00003.obj") && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return pid;
  };
  for (const int sig : {SIGTERM, SIGHUP}) {
    const fs::path out = dir / ("stopped_" + std::to_string(sig));
    fs::remove_all(out);
    const pid_t pid = start(out, false);
    ASSERT_GT(pid, 0);
    kill(pid, sig);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFEXITED(status)) << sig << ": " << slurp(dir / "child.txt");
    EXPECT_EQ(WEXITSTATUS(status), 128 + sig) << slurp(dir / "child.txt");
    const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
    EXPECT_FALSE(j["completed"].get<bool>());
    EXPECT_TRUE(j["interrupted"].get<bool>());
    EXPECT_GE(j["frames"].get<int>(), 3);
    EXPECT_TRUE(fs::exists(out / "checkpoint" / "checkpoint.bin"));
    const auto r = loom::test::run_loom("run --resume " + out.string() + " --frames " +
                                        std::to_string(j["frames"].get<int>() + 2));
    EXPECT_EQ(r.code, 0) << r.err;
  }
  const fs::path out = dir / "nohup";
  fs::remove_all(out);
  const pid_t pid = start(out, true);
  ASSERT_GT(pid, 0);
  kill(pid, SIGHUP);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  int status = 0;
  EXPECT_EQ(waitpid(pid, &status, WNOHANG), 0) << "a SIGHUP ignored by the parent stopped the run";
  kill(pid, SIGINT);
  waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 130) << slurp(dir / "child.txt");
}

TEST(Checkpoint, SigintStopsAtAFrameBoundaryAndResumesBitIdentically) {
  const fs::path dir = loom::test::test_dir();
  // Many substeps so a frame takes a few milliseconds and the run is still going when the signal comes.
  std::string text = kScene;
  text.replace(text.find("\"substeps\": 2"), 13, "\"substeps\": 40");
  const std::string scene = write_scene(dir, text);
  const fs::path out = dir / "interrupted", whole = dir / "whole";
  fs::remove_all(out);
  fs::remove_all(whole);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string log = (dir / "child.txt").string();
    if (!freopen(log.c_str(), "w", stdout) || !freopen(log.c_str(), "a", stderr)) _exit(99);
    execl(LOOM_BINARY, LOOM_BINARY, "run", scene.c_str(), "--frames", "99999", "--out", out.string().c_str(),
          (char*)nullptr);
    _exit(98);
  }
  // Wait for frame 5 on disk, then Ctrl-C.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(out / "frames" / "frame_00005.obj") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  kill(pid, SIGINT);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status)) << slurp(dir / "child.txt");
  EXPECT_EQ(WEXITSTATUS(status), 130) << slurp(dir / "child.txt");
  EXPECT_NE(slurp(dir / "child.txt").find("--resume"), std::string::npos);
  const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_FALSE(j["completed"].get<bool>());
  EXPECT_TRUE(j["interrupted"].get<bool>());
  EXPECT_TRUE(j["finite"].get<bool>());
  const int stopped = j["frames"].get<int>();
  ASSERT_GE(stopped, 5);
  ASSERT_LT(stopped, 99999);  // 5-digit frame names (frame_NNNNN.obj) below 100000 frames
  // Valid outputs: one stats row and one OBJ per frame done, nothing beyond.
  char next[32];
  std::snprintf(next, sizeof next, "frame_%05d.obj", stopped + 1);
  EXPECT_FALSE(fs::exists(out / "frames" / next));
  ASSERT_TRUE(fs::exists(out / "checkpoint" / "checkpoint.bin"));
  // Resume to stopped + 10 frames and compare with an uninterrupted run of as many frames.
  const int total = stopped + 10;
  auto r = loom::test::run_loom("run --resume " + out.string() + " --frames " + std::to_string(total));
  ASSERT_EQ(r.code, 0) << r.err;
  r = loom::test::run_loom("run " + scene + " --frames " + std::to_string(total) + " --out " +
                           whole.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(run_fingerprint(out, total), run_fingerprint(whole, total));
}

TEST(Guard, HopelessRunStopsWithSceneTimeAndCauseAndNoNaNAnywhere) {
  const fs::path dir = loom::test::test_dir();
  std::string text = kScene;
  text.replace(text.find("\"method\": \"bdf2\", \"substeps\": 2"), 31,
               "\"method\": \"explicit_euler\", \"substeps\": 1");
  text.replace(text.find("[\"obj\", \"pc2\"]"), 14, "[\"obj\", \"pc2\", \"gltf\"]");
  const std::string scene = write_scene(dir, text);
  const fs::path out = dir / "out";
  fs::remove_all(out);
  const auto r = loom::test::run_loom("run " + scene + " --frames 60 --out " + out.string());
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find(scene), std::string::npos) << r.err;
  EXPECT_TRUE(r.err.find("exploded") != std::string::npos || r.err.find("non-finite") != std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("(t = "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("substeps"), std::string::npos) << r.err;
  const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_FALSE(j["finite"].get<bool>());
  EXPECT_FALSE(j["completed"].get<bool>());
  EXPECT_GT(j["rollbacks"].get<int>(), 0);
  const int frames = j["frames"].get<int>();
  EXPECT_LT(frames, 60);
  for (const auto& e : fs::recursive_directory_iterator(out)) {
    if (!e.is_regular_file()) continue;
    const std::string body = slurp(e.path());
    // A non-finite number as text (nan, -nan, inf, NaN, Infinity), not inside a word.
    static const std::regex bad("(^|[^A-Za-z])-?(nan|NaN|NAN|inf|Inf|INF)([^A-Za-z]|$)");
    if (e.path().extension() != ".pc2" && e.path().extension() != ".bin") {
      EXPECT_FALSE(std::regex_search(body, bad)) << e.path() << " holds a non-finite number";
    }
    if (e.path().extension() == ".pc2" || e.path().extension() == ".bin") {
      // Binary floats: none non-finite.
      const size_t start = e.path().extension() == ".pc2" ? 32 : 0;
      for (size_t k = start; k + 4 <= body.size(); k += 4) {
        float f;
        std::memcpy(&f, body.data() + k, 4);
        ASSERT_TRUE(std::isfinite(f)) << e.path() << " at byte " << k;
      }
    }
  }
}

}  // namespace
