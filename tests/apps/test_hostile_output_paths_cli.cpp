// The output folder against paths that reach outside it (docs/guarantees.md): a folder inside it replaced by
// a link while files are written there, an --out that names a link through "." or "..", a default folder
// under a linked `out`, a hard-linked manifest on --resume, an input listed by an earlier run's manifest, a
// path a command writes that its pre-flight check did not see; and the command lines of fabric-test, compare
// and body checked before any folder exists.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
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

// A folder the earlier run listed ("frames/") replaced by the user's file: the next run into the folder
// leaves that file alone (it is not what the run made) and stops naming the path, exit 1.
TEST(HostileOutputPaths, AListedFolderReplacedByAFileIsLeftAlone) {
  const fs::path dir = test_dir(), out = dir / "out";
  const std::string scene = write_scene(dir);
  ASSERT_EQ(run_loom("run " + scene + " --frames 2 --out " + out.string()).code, 0);
  fs::remove_all(out / "frames");
  std::ofstream(out / "frames") << "precious";
  const auto r = run_loom("run " + scene + " --frames 2 --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find((out / "frames").string()), std::string::npos) << r.err;
  EXPECT_EQ(slurp(out / "frames"), "precious");
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

// Every file below `dir` with its bytes (links and folders by name).
std::map<std::string, std::string> snapshot(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string rel = e.path().lexically_relative(dir).string();
    files[rel] = e.is_symlink() ? "link" : e.is_directory() ? "folder" : slurp(e.path());
  }
  return files;
}

// Two commands never share an output folder: each holds an exclusive lock (flock) on the folder from before
// it reads anything there. A folder another process holds is refused by name, exit 1, before any file in it
// is read, deleted or written, whatever the command and whatever --overwrite says; `body --image` does not
// write its PNG into it either.
TEST(HostileOutputPaths, AFolderInUseByAnotherCommandIsRefusedAndLeftAsItWas) {
  const fs::path dir = test_dir(), out = dir / "busy";
  const std::string scene = write_scene(dir);
  ASSERT_EQ(run_loom("run " + scene + " --frames 2 --checkpoint-every 1 --out " + out.string()).code, 0);
  std::ofstream(out / "notes.txt") << "user data";
  const auto before = snapshot(out);
  const int fd = ::open(out.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX | LOCK_NB), 0);
  const std::string o = " --out " + out.string();
  for (const std::string& args : std::vector<std::string>{
           "run " + scene + " --frames 2" + o, "run " + scene + " --frames 2 --overwrite" + o,
           "run --resume " + out.string() + " --frames 3", "compare " + scene + " --frames 2 --overwrite" + o,
           "fabric-test catenary --overwrite" + o, "bench accuracy --quick --methods verlet --overwrite" + o,
           "bench realtime --quick --scenes sheet --overwrite" + o,
           "body " + std::string(LOOM_TEST_DATA) + "/body/human.zae " + std::string(LOOM_TEST_DATA) +
               "/mocap/01_01.bvh --seconds 0.05 --image " + (out / "summary.json").string()}) {
    const auto r = run_loom(args);
    if (r.err.find("unknown command") != std::string::npos) continue;  // a build without Bullet
    if (r.err.find("no renderer") != std::string::npos) continue;      // nor OSMesa (body --image)
    EXPECT_EQ(r.code, 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(out.string() + ": in use by another loom command"), std::string::npos)
        << args << ": " << r.err;
    EXPECT_EQ(snapshot(out), before) << args;
  }
  ::close(fd);  // released: the folder is Loom's again
  EXPECT_EQ(run_loom("run " + scene + " --frames 2" + o).code, 0);
}

// Folders nest: a command holds a shared lock on every folder above its own (FolderLock). While a run uses
// `conc`, a command into a folder inside it (its frames/ with --overwrite, a new conc/sub) is refused, exit
// 1, naming both folders, whatever the command, and so is a command into a folder that contains `conc`; none
// of them writes anything there (no manifest, no stats, no folder).
TEST(HostileOutputPaths, AFolderInsideOrAroundOneInUseIsRefused) {
  const fs::path dir = test_dir(), top = dir / "o", out = top / "conc";
  fs::create_directories(top);
  std::string text = kScene;
  text.replace(text.find("\"duration\": 0.1"), 15, "\"duration\": 600");
  text.replace(text.find("\"nodes\": [5, 5]"), 15, "\"nodes\": [40, 40]");
  text.replace(text.find("\"substeps\": 4"), 13, "\"substeps\": 200");
  const std::string scene = write_scene(dir, text);
  const std::string err = (dir / "long_err.txt").string();
  const pid_t pid = start_run({scene, "--out", out.string()}, err);
  for (int k = 0; k < 1500 && !fs::exists(out / "frames" / "frame_00001.obj"); ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_TRUE(fs::exists(out / "frames" / "frame_00001.obj")) << slurp(err);
  const std::string held = fs::canonical(out).string();
  const std::string body = "body " + std::string(LOOM_TEST_DATA) + "/body/human.zae " +
                           std::string(LOOM_TEST_DATA) + "/mocap/01_01.bvh --seconds 0.05 --image ";
  struct Case {
    std::string args;
    fs::path named;  // the folder the refusal names first
  };
  const fs::path frames = out / "frames", sub = out / "sub";
  const std::vector<Case> inside = {
      {"run " + scene + " --frames 1 --overwrite --out " + frames.string(), frames},
      {"run " + scene + " --frames 1 --out " + sub.string(), sub},
      {"run " + scene + " --frames 1 --out " + (sub / "deeper").string(), sub / "deeper"},
      {"compare " + scene + " --frames 1 --out " + sub.string(), sub},
      {"fabric-test catenary --resolution 8 --out " + sub.string(), sub},
      {"bench accuracy --quick --methods verlet --out " + sub.string(), sub},
      {"bench realtime --quick --scenes sheet --out " + sub.string(), sub},
      {body + (frames / "pic.png").string(), frames}};
  for (const Case& c : inside) {
    const auto r = run_loom(c.args);
    if (r.err.find("unknown command") != std::string::npos) continue;  // a build without Bullet
    if (r.err.find("no renderer") != std::string::npos) continue;      // nor OSMesa (body --image)
    EXPECT_EQ(r.code, 1) << c.args << ": " << r.err;
    EXPECT_NE(r.err.find(c.named.string() + ": in use by another loom command (it lies inside " + held +
                         ", which another loom command is using)"),
              std::string::npos)
        << c.args << ": " << r.err;
  }
  EXPECT_FALSE(fs::exists(sub));
  for (const char* name : {".loom-manifest", "stats.csv", "stats.csv.partial", "summary.json", "pc2",
                           "checkpoint", "pic.png", "compare.json"})
    EXPECT_FALSE(fs::exists(frames / name)) << name;
  // A folder that contains the one in use: refused naming both, --overwrite or not.
  for (const std::string& args : {"run " + scene + " --frames 1 --overwrite --out " + top.string(),
                                  "compare " + scene + " --frames 1 --overwrite --out " + top.string(),
                                  "fabric-test catenary --resolution 8 --overwrite --out " + top.string()}) {
    const auto r = run_loom(args);
    if (r.err.find("unknown command") != std::string::npos) continue;  // a build without Bullet
    EXPECT_EQ(r.code, 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(top.string() + ": in use by another loom command (it contains " + held +
                         ", which another loom command is using)"),
              std::string::npos)
        << args << ": " << r.err;
  }
  EXPECT_EQ(count_entries(top), 1u);  // conc alone
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  // The run is gone, its locks with it: a folder beside the listed ones is usable again.
  EXPECT_EQ(run_loom("run " + write_scene(dir) + " --frames 1 --out " + sub.string()).code, 0);
}

// A folder an earlier run made (its manifest lists it: frames/, pc2/, checkpoint/) belongs to that run: an
// --out there or below is refused, with --overwrite too (the next run into the folder deletes what it lists),
// naming the folder and the entry, before anything changes. A new folder beside the listed ones is not
// refused and the earlier run's folder leaves it alone; a command whose output folder holds another run's
// folder where it writes is refused.
TEST(HostileOutputPaths, AnOutInsideAFolderAnEarlierRunListedIsRefused) {
  const fs::path dir = test_dir(), out = dir / "done";
  const std::string scene = write_scene(dir);
  ASSERT_EQ(run_loom("run " + scene + " --frames 2 --checkpoint-every 1 --out " + out.string()).code, 0);
  const auto before = snapshot(out);
  const std::string held = fs::canonical(out).string();
  for (const auto& [target, entry] :
       std::vector<std::pair<fs::path, std::string>>{{out / "frames", "frames"},
                                                     {out / "frames" / "deeper", "frames"},
                                                     {out / "pc2", "pc2"},
                                                     {out / "checkpoint", "checkpoint"},
                                                     {out / "stats.csv" / "x", "stats.csv"}})
    for (const char* extra : {"", " --overwrite"}) {
      const auto r = run_loom("run " + scene + " --frames 1 --out " + target.string() + extra);
      EXPECT_EQ(r.code, 1) << target << extra << ": " << r.err;
      EXPECT_NE(
          r.err.find(target.string() + ": --out: lies inside " + held +
                     ", the output folder of an earlier loom run, whose .loom-manifest lists '" + entry),
          std::string::npos)
          << target << extra << ": " << r.err;
      EXPECT_EQ(snapshot(out), before) << target << extra;
    }
  const fs::path sub = out / "sub";
  ASSERT_EQ(run_loom("run " + scene + " --frames 1 --out " + sub.string()).code, 0);
  ASSERT_EQ(run_loom("run " + scene + " --frames 1 --out " + out.string()).code, 0);
  EXPECT_TRUE(fs::exists(sub / "summary.json"));
  // `outer` holds a run's folder at frames/, where a run into `outer` writes its frames.
  const fs::path outer = dir / "outer";
  ASSERT_EQ(run_loom("run " + scene + " --frames 1 --out " + (outer / "frames").string()).code, 0);
  const auto inner = snapshot(outer);
  const auto r = run_loom("run " + scene + " --frames 1 --overwrite --out " + outer.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find((outer / "frames").string() +
                       ": --out: is the output folder of another loom run (it holds .loom-manifest)"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(snapshot(outer), inner);
}

// A manifest entry is deleted only as the type it was listed as (a link is removed itself, never followed):
// a listed folder found as a file, FIFO or socket, and a listed file found as a folder or FIFO, are left
// alone. Where the run writes such a path the run is refused before anything in the folder changes (the
// earlier run's other files are still there). A `.loom-manifest` that is a FIFO is described as one.
TEST(HostileOutputPaths, AListedPathOfAnotherTypeIsLeftAlone) {
  const fs::path dir = test_dir(), out = dir / "out";
  const std::string scene = write_scene(dir);
  ASSERT_EQ(run_loom("run " + scene + " --frames 2 --out " + out.string()).code, 0);
  {
    std::ofstream manifest(out / ".loom-manifest", std::ios::app);
    manifest << "was_folder/\nfifo_folder/\nsock_folder/\nwas_file\nfifo_file\n";
  }
  std::ofstream(out / "was_folder") << "user data";
  ASSERT_EQ(::mkfifo((out / "fifo_folder").c_str(), 0600), 0);
  const int sock = ::socket(AF_UNIX, SOCK_STREAM, 0);
  ASSERT_GE(sock, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string sock_path = (out / "sock_folder").string();
  ASSERT_LT(sock_path.size(), sizeof addr.sun_path) << sock_path;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", sock_path.c_str());
  ASSERT_EQ(::bind(sock, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  fs::create_directories(out / "was_file");
  std::ofstream(out / "was_file" / "notes.txt") << "user data";
  ASSERT_EQ(::mkfifo((out / "fifo_file").c_str(), 0600), 0);
  const auto r = run_loom("run " + scene + " --frames 2 --out " + out.string());
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(slurp(out / "was_folder"), "user data");
  EXPECT_TRUE(fs::is_fifo(fs::symlink_status(out / "fifo_folder")));
  EXPECT_TRUE(fs::is_socket(fs::symlink_status(out / "sock_folder")));
  EXPECT_EQ(slurp(out / "was_file" / "notes.txt"), "user data");
  EXPECT_TRUE(fs::is_fifo(fs::symlink_status(out / "fifo_file")));
  ::close(sock);
  // frames/ (listed as a folder, written by the run) found as a file: refused before the old files go.
  fs::remove_all(out / "frames");
  std::ofstream(out / "frames") << "precious";
  ASSERT_TRUE(fs::exists(out / "pc2" / "sheet.pc2"));
  const auto refused = run_loom("run " + scene + " --frames 2 --out " + out.string());
  EXPECT_EQ(refused.code, 1) << refused.err;
  EXPECT_NE(refused.err.find((out / "frames").string() + ": --out: is a file where Loom writes a folder"),
            std::string::npos)
      << refused.err;
  EXPECT_EQ(slurp(out / "frames"), "precious");
  EXPECT_TRUE(fs::exists(out / "pc2" / "sheet.pc2")) << "the refused run deleted the earlier run's files";
  // The manifest itself a FIFO: named by its type, never opened.
  const fs::path other = dir / "other";
  fs::create_directories(other);
  ASSERT_EQ(::mkfifo((other / ".loom-manifest").c_str(), 0600), 0);
  const auto fifo = run_loom("run " + scene + " --frames 1 --out " + other.string());
  EXPECT_EQ(fifo.code, 1) << fifo.err;
  EXPECT_NE(fifo.err.find((other / ".loom-manifest").string() +
                          ": --out: is not a regular file (it is a FIFO): not a folder Loom owns"),
            std::string::npos)
      << fifo.err;
}

// `loom compare` never replaces its own inputs: a scene or a mesh that is (by device and inode) a file
// compare writes is refused, with --overwrite or not, as is one an earlier compare listed (deleted first).
TEST(HostileOutputPaths, CompareNeverReplacesItsOwnSceneOrMesh) {
  const fs::path dir = test_dir();
  const std::string text = kScene;
  // The scene at DIR/compare.json, --overwrite.
  const fs::path cx = dir / "cx";
  fs::create_directories(cx);
  std::ofstream(cx / "compare.json") << text;
  auto r =
      run_loom("compare " + (cx / "compare.json").string() + " --frames 2 --overwrite --out " + cx.string());
  if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "built without Bullet";
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find((cx / "compare.json").string() + ": --out: is an input"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(cx / "compare.json"), text);
  EXPECT_FALSE(fs::exists(cx / "compare.csv"));
  // The scene where an earlier compare wrote compare.json, no --overwrite needed to reach it.
  const fs::path cx4 = dir / "cx4";
  const std::string scene = write_scene(dir);
  ASSERT_EQ(run_loom("compare " + scene + " --frames 2 --out " + cx4.string()).code, 0);
  fs::remove(cx4 / "compare.json");
  std::ofstream(cx4 / "compare.json") << text;
  r = run_loom("compare " + (cx4 / "compare.json").string() + " --frames 2 --out " + cx4.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("is an input"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(cx4 / "compare.json"), text);
  // A cloth mesh at DIR/compare.csv.
  const fs::path cx5 = dir / "cx5";
  fs::create_directories(cx5);
  const std::string obj = "v 0 1 0\nv 1 1 0\nv 0 1 1\nv 1 1 1\nf 1 2 4\nf 1 4 3\n";
  std::ofstream(cx5 / "compare.csv") << obj;
  r = run_loom(
      "compare " + scene + " --frames 2 --overwrite --out " + cx5.string() +
      " --set 'cloths[0].mesh={\"type\":\"obj\",\"path\":\"cx5/compare.csv\"}' --set 'cloths[0].pins=[]'");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("compare.csv: --out: is an input"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(cx5 / "compare.csv"), obj);
}

// `loom bench realtime` never writes over a file its scenes read: a collider mesh of a benchmark scene at the
// path of a file the benchmark writes is refused before anything runs (by `colliders`, which the Bullet
// twins do not see, before its inputs are collected) and stays as it was.
TEST(HostileOutputPaths, BenchRealtimeNeverReplacesAMeshItReads) {
  const fs::path dir = test_dir(), lsc = dir / "lsc";
  fs::create_directories(lsc);
  std::string toy = slurp(fs::path(LOOM_SOURCE_DIR) / "scenes" / "toy_box.json");
  const size_t at = toy.find("\"quality\"");
  ASSERT_NE(at, std::string::npos);
  toy.insert(at,
             "\"colliders\": [{\"name\": \"tri\", \"shape\": \"mesh\", \"obj\": \"toy_box_realtime.dat\", "
             "\"position\": [50, -10, 50]}],\n  ");
  std::ofstream(lsc / "toy_box.json") << toy;
  const std::string mesh = "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n";
  std::ofstream(lsc / "toy_box_realtime.dat") << mesh;
  const std::string line = "LOOM_SCENES=" + lsc.string() + " " + LOOM_BINARY +
                           " bench realtime --quick --scenes toy_box --overwrite --out " + lsc.string() +
                           " >" + (dir / "o.txt").string() + " 2>" + (dir / "e.txt").string();
  const int status = std::system(line.c_str());
  const std::string e = slurp(dir / "e.txt");
  if (e.find("unknown command") != std::string::npos) GTEST_SKIP() << "built without Bullet";
  EXPECT_EQ(WEXITSTATUS(status), 1) << e;
  EXPECT_NE(e.find("toy_box.json: colliders: "), std::string::npos) << e;
  EXPECT_EQ(slurp(lsc / "toy_box_realtime.dat"), mesh);
  EXPECT_FALSE(fs::exists(lsc / "toy_box_realtime.csv"));
}

// The output folder the user named is printed with its control characters as \xNN in every success
// message: an escape sequence or a newline in --out never reaches the terminal raw.
TEST(HostileOutputPaths, SuccessMessagesShowTheOutputFolderEscaped) {
  const fs::path dir = test_dir();
  const std::string scene = write_scene(dir);
  const std::string odd = "r\x1b[2Jx\ny";
  struct Row {
    std::string args, printed;
  };
  for (const Row& row : std::vector<Row>{
           {"compare " + scene + " --frames 2 --out '" + (dir / (odd + "c")).string() + "'", "wrote"},
           {"bench accuracy --quick --methods verlet --sizes 8 --threads 1 --out '" +
                (dir / (odd + "b")).string() + "'",
            "wrote"},
           {"run " + scene + " --frames 2 --render --out '" + (dir / (odd + "r")).string() + "'",
            "rendered"}}) {
    const auto r = run_loom(row.args);
    if (r.err.find("unknown command") != std::string::npos ||
        r.err.find("without the offscreen renderer") != std::string::npos ||
        r.err.find("ffmpeg not found") != std::string::npos)
      continue;
    EXPECT_EQ(r.code, 0) << row.args << ": " << r.err;
    EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << row.args << ": " << r.out;
    EXPECT_NE(r.out.find("r\\x1b[2Jx\\x0ay"), std::string::npos) << row.args << ": " << r.out;
    EXPECT_NE(r.out.find(row.printed), std::string::npos) << row.args << ": " << r.out;
    EXPECT_EQ(r.out.find("\ny"), std::string::npos) << row.args << ": " << r.out;  // no line broken by it
  }
}

// A render (OSMesa) writes nothing outside its output folder: Mesa's shader cache, kept in $XDG_CACHE_HOME or
// ~/.cache, is off.
TEST(HostileOutputPaths, ARenderWritesNoShaderCache) {
  const fs::path dir = test_dir(), cache = dir / "xdg_cache", home = dir / "home";
  fs::create_directories(cache);
  fs::create_directories(home);
  const std::string scene = write_scene(dir);
  const std::string line = "XDG_CACHE_HOME=" + cache.string() + " HOME=" + home.string() + " " + LOOM_BINARY +
                           " run " + scene + " --frames 2 --render --out " + (dir / "out").string() + " >" +
                           (dir / "o.txt").string() + " 2>" + (dir / "e.txt").string();
  const int status = std::system(line.c_str());
  const std::string e = slurp(dir / "e.txt");
  if (e.find("without the offscreen renderer") != std::string::npos ||
      e.find("ffmpeg not found") != std::string::npos)
    GTEST_SKIP() << e;
  EXPECT_EQ(WEXITSTATUS(status), 0) << e;
  EXPECT_FALSE(fs::is_empty(dir / "out" / "render")) << e;
  EXPECT_EQ(count_entries(cache), 0u);
  EXPECT_EQ(count_entries(home), 0u);
}

}  // namespace
}  // namespace loom::test
