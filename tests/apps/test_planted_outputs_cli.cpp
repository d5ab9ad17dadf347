// What a running `loom run` meets in its output folder after the pre-flight check (OutputFolder.h) passed:
// a FIFO, a symbolic link or a hard link planted at a path it writes later is refused by name (or, for a
// hard link, replaced by a new file) and never blocks the run or reaches a file Loom did not write
// (OutputFile.h). And Ctrl-C stops a scene with rigid bodies within a long frame, as it does a cloth-only
// scene.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "CliRunner.h"

namespace loom::test {
namespace {

namespace fs = std::filesystem;

struct Child {
  pid_t pid = -1;
  std::string err;  // file holding its stderr
};

// Starts `loom run` with `args` (stdout to /dev/null, stderr to a file of the test's folder).
Child start_loom(const std::vector<std::string>& args) {
  Child c;
  c.err = (test_dir() / "child_err.txt").string();
  std::vector<char*> argv = {const_cast<char*>(LOOM_BINARY), const_cast<char*>("run")};
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  c.pid = ::fork();
  if (c.pid == 0) {
    if (!std::freopen(c.err.c_str(), "w", stderr) || !std::freopen("/dev/null", "w", stdout)) ::_exit(99);
    ::execv(LOOM_BINARY, argv.data());
    ::_exit(98);
  }
  return c;
}

// The exit code, or -1 after `seconds` (the child is then killed: the run hung or ran on).
int wait_exit(const Child& c, int seconds) {
  int status = 0;
  for (int k = 0; k < 10 * seconds; ++k) {
    if (::waitpid(c.pid, &status, WNOHANG) == c.pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -2;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ::kill(c.pid, SIGKILL);
  ::waitpid(c.pid, &status, 0);
  return -1;
}

bool wait_for(const fs::path& p, int seconds) {
  for (int k = 0; k < 10 * seconds && !fs::exists(p); ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  return fs::exists(p);
}

// Substeps per frame that make a frame of hanging_cloth take seconds: fewer in the sanitizer build, whose
// `loom` runs each step many times slower (every test must end within ctest's 300 s).
constexpr const char* kSlowSubsteps = kAddressSanitizer ? "solver.substeps=2000" : "solver.substeps=40000";

// A run of 4 frames of hanging_cloth slow enough (many substeps) that frame 0 is on disk long before the
// last frame and summary.json are written.
std::vector<std::string> slow_run(const fs::path& out) {
  return {std::string(LOOM_SOURCE_DIR) + "/scenes/hanging_cloth.json",
          "--out",
          out.string(),
          "--frames",
          "4",
          "--set",
          kSlowSubsteps};
}

TEST(PlantedOutputs, AFifoPlantedAtALaterFrameIsRefusedByNameAndNeverBlocks) {
  const fs::path out = test_dir() / "out";
  const Child c = start_loom(slow_run(out));
  ASSERT_TRUE(wait_for(out / "frames" / "frame_00000.obj", 120)) << slurp(c.err);
  const fs::path fifo = out / "frames" / "frame_00003.obj";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const int code = wait_exit(c, 300);
  ASSERT_NE(code, -1) << "the run blocked on the FIFO";
  EXPECT_EQ(code, 1) << slurp(c.err);
  // Named by the output folder's claim (OutputFolder.h) or, planted after it, by the open (OutputFile.h).
  EXPECT_NE(slurp(c.err).find(fifo.string() + ": "), std::string::npos) << slurp(c.err);
  EXPECT_NE(slurp(c.err).find("FIFO"), std::string::npos) << slurp(c.err);
  EXPECT_TRUE(fs::is_fifo(fs::symlink_status(fifo)));  // left where it was planted
}

TEST(PlantedOutputs, ALinkPlantedAtTheSummaryTemporaryIsRefusedAndItsTargetUntouched) {
  const fs::path dir = test_dir(), out = dir / "out", victim = dir / "victim.txt";
  std::ofstream(victim) << "precious";
  const Child c = start_loom(slow_run(out));
  ASSERT_TRUE(wait_for(out / "frames" / "frame_00000.obj", 120)) << slurp(c.err);
  fs::create_symlink(victim, out / "summary.json.tmp");
  const int code = wait_exit(c, 300);
  ASSERT_NE(code, -1) << slurp(c.err);
  EXPECT_EQ(code, 1) << slurp(c.err);
  EXPECT_NE(slurp(c.err).find((out / "summary.json.tmp").string() + ": "), std::string::npos) << slurp(c.err);
  EXPECT_NE(slurp(c.err).find("is a symbolic link"), std::string::npos) << slurp(c.err);
  EXPECT_EQ(slurp(victim), "precious");
}

// A hard link to a user's file planted at a frame path during the run: the output folder's claim of that
// frame refuses it by name (as it does before the run, OutputFolder.h), and the user's file keeps its bytes.
TEST(PlantedOutputs, AHardLinkPlantedAtALaterFrameIsRefusedNotWrittenThrough) {
  const fs::path dir = test_dir(), out = dir / "out", victim = dir / "victim.txt";
  std::ofstream(victim) << "precious";
  const Child c = start_loom(slow_run(out));
  ASSERT_TRUE(wait_for(out / "frames" / "frame_00000.obj", 120)) << slurp(c.err);
  const fs::path link = out / "frames" / "frame_00004.obj";
  fs::create_hard_link(victim, link);
  const int code = wait_exit(c, 300);
  ASSERT_NE(code, -1) << slurp(c.err);
  EXPECT_EQ(code, 1) << slurp(c.err);
  EXPECT_NE(slurp(c.err).find(link.string() + ": "), std::string::npos) << slurp(c.err);
  EXPECT_NE(slurp(c.err).find("is a hard link"), std::string::npos) << slurp(c.err);
  EXPECT_EQ(slurp(victim), "precious");
  EXPECT_EQ(slurp(link), "precious");  // left where it was planted, not written through
}

// Ctrl-C in a Bullet-world scene: a frame of 1,000,000 cloth steps (minutes) is abandoned within the frame;
// the run exits 130 with frame 0 written, summary.json interrupted and no checkpoint (the world is not
// saved).
TEST(PlantedOutputs, SigintStopsABulletSceneWithinALongFrame) {
  const fs::path out = test_dir() / "out";
  const Child c =
      start_loom({std::string(LOOM_SOURCE_DIR) + "/scenes/toy_box.json", "--out", out.string(), "--frames",
                  "3", "--set", "solver={\"method\":\"symplectic_euler\",\"substeps\":1000000}"});
  ASSERT_TRUE(wait_for(out / "frames" / "frame_00000.obj", 120)) << slurp(c.err);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_EQ(::kill(c.pid, SIGINT), 0);
  const int code = wait_exit(c, 60);
  ASSERT_NE(code, -1) << "the run did not stop within the frame";
  EXPECT_EQ(code, 130) << slurp(c.err);
  EXPECT_NE(slurp(c.err).find("loom: interrupted after frame 0 of 3"), std::string::npos) << slurp(c.err);
  const auto summary = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(summary["frames"], 0);
  EXPECT_EQ(summary["interrupted"], true);
  EXPECT_EQ(summary["completed"], false);
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00001.obj"));
  EXPECT_FALSE(fs::exists(out / "checkpoint"));
  EXPECT_TRUE(fs::exists(out / "stats.csv"));
}

}  // namespace
}  // namespace loom::test
