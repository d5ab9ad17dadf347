// The output folder against paths that reach outside it (docs/guarantees.md): a folder inside it replaced by
// a link while files are written there, an --out that names a link through "." or "..", a default folder
// under a linked `out`, a hard-linked manifest on --resume, an input listed by an earlier run's manifest, a
// path a command writes that its pre-flight check did not see; and the command lines of fabric-test, compare
// and body checked before any folder exists.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "CliRunner.h"
#include "OutputFolderScene.h"

namespace loom::test {
namespace {

namespace fs = std::filesystem;

const char* kScene = kOutputFolderScene;

size_t count_entries(const fs::path& dir) {
  return static_cast<size_t>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

// `loom run ARGS` in the background (stdout to /dev/null, stderr to `err`).
pid_t start_run(const std::vector<std::string>& args, const std::string& err) {
  std::vector<char*> argv = {const_cast<char*>(LOOM_BINARY), const_cast<char*>("run")};
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (!std::freopen(err.c_str(), "w", stderr) || !std::freopen("/dev/null", "w", stdout)) ::_exit(99);
    ::execv(LOOM_BINARY, argv.data());
    ::_exit(98);
  }
  return pid;
}

// The exit code, or -1 after `seconds` (the child is then killed).
int wait_exit(pid_t pid, int seconds) {
  int status = 0;
  for (int k = 0; k < 10 * seconds; ++k) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -2;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return -1;
}

// --render claims every PNG frame, then writes them one by one: `render/` renamed away and replaced by a
// link to a foreign folder while they are written is refused by name at the next frame, and the foreign
// folder gets nothing (every write walks the folders from the output folder's descriptor, OutputFile.h).
TEST(HostileOutputPaths, ARenderFolderReplacedByALinkDuringTheRunIsNeverFollowed) {
  const fs::path dir = test_dir(), out = dir / "rr", outside = dir / "outside";
  fs::create_directories(outside);
  std::ofstream(outside / "notes.txt") << "user data";
  std::string text = kScene;
  text.replace(text.find("\"duration\": 0.1"), 15, "\"duration\": 2");
  text.replace(text.find("\"output\": {"), 11,
               "\"output\": {\"render\": {\"width\": 640, \"height\": 480}, ");
  const std::string scene = write_scene(dir, text);
  const std::string err = (dir / "child_err.txt").string();
  const pid_t pid = start_run({scene, "--out", out.string(), "--render"}, err);
  const fs::path third = out / "render" / "frame_00003.png";
  for (int k = 0; k < 1200 && !fs::exists(third); ++k) {
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      const std::string e = slurp(err);
      if (e.find("without the offscreen renderer") != std::string::npos ||
          e.find("ffmpeg not found") != std::string::npos)
        GTEST_SKIP() << "no renderer or ffmpeg: " << e;
      FAIL() << "the run ended before its fourth PNG: " << e;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(fs::exists(third)) << slurp(err);
  fs::rename(out / "render", out / "render.moved");
  fs::create_directory_symlink(outside, out / "render");
  const int code = wait_exit(pid, 300);
  ASSERT_NE(code, -1) << slurp(err);
  // The run may have written its last PNG before the link appeared; then it fails on the video instead.
  EXPECT_EQ(count_entries(outside), 1u) << "Loom wrote through the link";
  EXPECT_EQ(slurp(outside / "notes.txt"), "user data");
  if (fs::exists(out / "render.moved" / "frame_00119.png")) GTEST_SKIP() << "the render ended first";
  EXPECT_EQ(code, 1) << slurp(err);
  EXPECT_NE(slurp(err).find((out / "render").string() + ": is a symbolic link"), std::string::npos)
      << slurp(err);
}

// "LINK/." and "LINK/./" name the folder behind the link: refused as the link itself is, in every command
// with --out, and what the link points to is left as it was.
TEST(HostileOutputPaths, AnOutThatEndsInDotIsRefused) {
  const fs::path dir = test_dir(), real = dir / "real", link = dir / "lnk";
  const std::string scene = write_scene(dir);
  fs::create_directories(real);
  std::ofstream(real / "notes.txt") << "user data";
  fs::create_directory_symlink(real, link);
  for (const std::string& cmd :
       std::vector<std::string>{"run " + scene + " --frames 1", "run " + scene + " --frames 1 --overwrite",
                                "compare " + scene + " --frames 1", "fabric-test catenary --resolution 8",
                                "bench accuracy --quick", "bench realtime --quick"})
    for (const char* tail : {"/.", "/./", "/..", "/../"}) {
      const auto r = run_loom(cmd + " --out " + link.string() + tail);
      if (r.err.find("unknown command") != std::string::npos) break;  // a build without Bullet
      EXPECT_EQ(r.code, 1) << cmd << tail << ": " << r.err;
      EXPECT_NE(r.err.find("--out: ends in '."), std::string::npos) << cmd << tail << ": " << r.err;
    }
  EXPECT_EQ(count_entries(real), 1u);
  EXPECT_EQ(slurp(real / "notes.txt"), "user data");
}

// Without --out Loom picks out/<name>: when `out` is a link, the user never named it, so it is refused.
TEST(HostileOutputPaths, ADefaultFolderUnderALinkIsRefused) {
  const fs::path dir = test_dir(), real = dir / "elsewhere";
  const std::string scene = write_scene(dir);
  fs::create_directories(real);
  fs::create_directory_symlink(real, dir / "out");
  for (const std::string& cmd :
       std::vector<std::string>{"run " + scene + " --frames 1", "fabric-test catenary --resolution 8"}) {
    const std::string line = "cd " + dir.string() + " && " + LOOM_BINARY + " " + cmd + " >" +
                             (dir / "o.txt").string() + " 2>" + (dir / "e.txt").string();
    const int status = std::system(line.c_str());
    const std::string e = slurp(dir / "e.txt");
    EXPECT_EQ(WEXITSTATUS(status), 1) << cmd << ": " << e;
    EXPECT_NE(e.find("out: --out: is a symbolic link on the way to the default output folder"),
              std::string::npos)
        << cmd << ": " << e;
  }
  EXPECT_EQ(count_entries(real), 0u);
}

// --resume appends to the manifest: one that shares its data with another name (a hard link) is refused
// before anything changes, and the other name keeps its bytes.
TEST(HostileOutputPaths, ResumeRefusesAHardLinkedManifest) {
  const fs::path dir = test_dir(), out = dir / "out", backup = dir / "backup.txt";
  const std::string scene = write_scene(dir);
  ASSERT_EQ(run_loom("run " + scene + " --frames 2 --checkpoint-every 1 --out " + out.string()).code, 0);
  fs::create_hard_link(out / ".loom-manifest", backup);
  const std::string before = slurp(backup);
  const auto r = run_loom("run --resume " + out.string() + " --frames 4");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find((out / ".loom-manifest").string() + ": --resume: is a hard link"), std::string::npos)
      << r.err;
  EXPECT_EQ(slurp(backup), before);
}

// A new run deletes the files an earlier run listed: an input among them (the scene's mesh is the earlier
// run's pc2/sheet.obj; the new cloth, "cape", writes pc2/cape.obj, not that path) is refused by name before
// anything in the folder changes.
TEST(HostileOutputPaths, AnInputListedByTheOldManifestIsRefusedNotDeleted) {
  const fs::path dir = test_dir(), out = dir / "out";
  const std::string first = write_scene(dir);
  ASSERT_EQ(run_loom("run " + first + " --frames 1 --out " + out.string()).code, 0);
  const fs::path mesh = out / "pc2" / "sheet.obj";
  ASSERT_TRUE(fs::exists(mesh));
  const std::string mesh_text = slurp(mesh);
  const std::string text = std::string(R"({
  "duration": 0.1, "fps": 60,
  "cloths": [{"name": "cape", "mesh": {"type": "obj", "path": ")") +
                           mesh.string() + R"("},
              "material": {"preset": "cotton"}, "mass": 0.2, "pins": [{"vertex": 0}]}],
  "output": {"formats": ["obj"]}
})";
  const fs::path second = dir / "second";
  fs::create_directories(second);
  const std::string scene = write_scene(second, text);
  for (const char* extra : {"", " --overwrite"}) {
    const std::string manifest = slurp(out / ".loom-manifest");
    const auto r = run_loom("run " + scene + " --frames 1 --out " + out.string() + extra);
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find(mesh.string() + ": --out: is an input of this run and a file an earlier run listed"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(slurp(mesh), mesh_text);
    EXPECT_EQ(slurp(out / ".loom-manifest"), manifest);
  }
  // Through another name of the same file too (compared by device and inode).
  fs::create_hard_link(mesh, second / "mesh.obj");
  std::string linked = text;
  linked.replace(linked.find(mesh.string()), mesh.string().size(), (second / "mesh.obj").string());
  const auto r = run_loom("run " + write_scene(second, linked) + " --frames 1 --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("a file an earlier run listed"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(mesh), mesh_text);
}

// Every path a command writes is in its pre-flight list: `bench accuracy` writes accuracy.png through
// accuracy.png.tmp, so a FIFO planted there is refused before the bench runs (no manifest written), not
// after.
TEST(HostileOutputPaths, BenchAccuracyChecksItsTemporaryFileBeforeItRuns) {
  const fs::path dir = test_dir(), out = dir / "bench";
  fs::create_directories(out);
  ASSERT_EQ(::mkfifo((out / "accuracy.png.tmp").c_str(), 0600), 0);
  const auto r = run_loom("bench accuracy --quick --overwrite --out " + out.string());
  if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "a build without Bullet";
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find((out / "accuracy.png.tmp").string() + ": --out: is not a regular file"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.out.find("N="), std::string::npos) << "the bench ran before the check: " << r.out;
  EXPECT_FALSE(fs::exists(out / ".loom-manifest"));
}

// fabric-test checks every option before its folder exists (a refused command leaves nothing behind), names
// the option, and an empty --out is a command-line error (exit 2) as in `loom run`; so is compare's.
TEST(HostileOutputPaths, FabricTestAndCompareCheckTheirCommandLineBeforeTheFolder) {
  const fs::path dir = test_dir(), out = dir / "ft";
  const std::string scene = write_scene(dir);
  struct Row {
    std::string args, names;
  };
  for (const Row& row : std::vector<Row>{{"tensile --solver bogus", "--solver: unknown solver 'bogus'"},
                                         {"tensile --resolution 4", "--resolution"},
                                         {"bogus_test", "test: unknown fabric test 'bogus_test'"},
                                         {"tensile --model bogus", "--model: unknown model 'bogus'"}}) {
    const auto r = run_loom("fabric-test " + row.args + " --out " + out.string());
    EXPECT_EQ(r.code, 1) << row.args << ": " << r.err;
    EXPECT_NE(r.err.find(row.names), std::string::npos) << row.args << ": " << r.err;
    EXPECT_FALSE(fs::exists(out)) << row.args;
  }
  // The parser and the test agree on --resolution's range.
  auto r = run_loom("fabric-test tensile --resolution 4 --out " + out.string());
  EXPECT_NE(r.err.find("[5, 2000]"), std::string::npos) << r.err;
  for (const std::string& cmd : std::vector<std::string>{"fabric-test tensile", "compare " + scene}) {
    const std::string line = "cd " + dir.string() + " && " + LOOM_BINARY + " " + cmd + " --out '' >" +
                             (dir / "o.txt").string() + " 2>" + (dir / "e.txt").string();
    const int status = std::system(line.c_str());
    const std::string e = slurp(dir / "e.txt");
    if (e.find("unknown command") != std::string::npos) continue;
    EXPECT_EQ(WEXITSTATUS(status), 2) << cmd << ": " << e;
    EXPECT_NE(e.find("--out: is an empty string"), std::string::npos) << cmd << ": " << e;
    EXPECT_FALSE(fs::exists(dir / "out")) << cmd;
  }
}

}  // namespace
}  // namespace loom::test
