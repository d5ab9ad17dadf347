// `loom run` against a careful user's and an attacker's files (docs/guarantees.md):
//   - the output folder is owned through DIR/.loom-manifest: a non-empty folder Loom did not write is refused
//     unless --overwrite, and even then nothing but the run's own files is deleted; a folder the run wrote
//     itself is reused (its earlier files, by the manifest, replaced); no link is written through;
//   - nothing outside the output folder is touched: the scene's name is never a path;
//   - checkpoints carry a format version, a checksum, the output folder's run id and the hash of every input,
//     and --resume refuses a mismatch by name before it changes any file;
//   - empty paths (unset shell variables) are errors; frame numbers past 99999 keep their sort order;
//   - memory and threads are bounded before anything is allocated; NaN is never written.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "CliRunner.h"
#include "OutputFolderScene.h"

namespace {

namespace fs = std::filesystem;
using loom::test::kOutputFolderScene;
using loom::test::run_loom;
using loom::test::slurp;
using loom::test::write_scene;

const char* kScene = kOutputFolderScene;

// `text` with its one `from` replaced by `to`.
std::string with(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

void write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << text;
}

// Files a user keeps in a folder, under names Loom also writes or used to delete.
const std::vector<std::string> kForeign = {
    "pc2/keep.pc2", "checkpoint/notes.txt",   "animation.gltf", "animation.bin",
    "bodies.csv",   "frames/frame_00007.obj", "mesh.obj",       "notes.txt"};

TEST(OutputFolder, RefusesAFolderItDidNotWriteAndTouchesNothing) {
  const fs::path dir = loom::test::test_dir(), out = dir / "mine";
  const std::string scene = write_scene(dir);
  for (const auto& f : kForeign) write(out / f, "user data " + f);
  const auto r = run_loom("run " + scene + " --frames 2 --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(out.string()), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--out"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--overwrite"), std::string::npos) << r.err;
  for (const auto& f : kForeign) EXPECT_EQ(slurp(out / f), "user data " + f) << f;
  EXPECT_FALSE(fs::exists(out / ".loom-manifest"));
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

TEST(OutputFolder, OverwriteDeletesOnlyTheRunsOwnFiles) {
  const fs::path dir = loom::test::test_dir(), out = dir / "mine";
  for (const auto& f : kForeign) write(out / f, "user data " + f);
  // The run's own input mesh lives in the folder.
  std::string text = kScene;
  write(out / "input.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0 1\nf 1 2 4\nf 1 4 3\n");
  text = with(text, "{\"type\": \"grid\", \"size\": [1, 1], \"nodes\": [5, 5], \"origin\": [-0.5, 1, -0.5]}",
              "{\"type\": \"obj\", \"path\": \"mine/input.obj\"}");
  text = with(text, "\"pins\": [{\"grid\": [0, 0]}, {\"grid\": [-1, 0]}]", "\"pins\": [{\"vertex\": 0}]");
  const std::string scene = write_scene(dir, text);
  const std::string input = slurp(out / "input.obj");
  auto r = run_loom("run " + scene + " --frames 2 --out " + out.string() + " --overwrite");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_00002.obj"));
  EXPECT_TRUE(fs::exists(out / ".loom-manifest"));
  EXPECT_EQ(slurp(out / "input.obj"), input);
  for (const auto& f : kForeign) {
    if (f != "animation.gltf" && f != "animation.bin") {
      EXPECT_EQ(slurp(out / f), "user data " + f) << f;
    }
  }
  // A second run into the folder (now Loom's, by its manifest) needs no --overwrite and still keeps them.
  r = run_loom("run " + scene + " --frames 1 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00002.obj"));  // the earlier run's, by the manifest
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_00001.obj"));
  EXPECT_EQ(slurp(out / "input.obj"), input);
  EXPECT_EQ(slurp(out / "frames" / "frame_00007.obj"), "user data frames/frame_00007.obj");
  EXPECT_EQ(slurp(out / "notes.txt"), "user data notes.txt");
}

TEST(OutputFolder, ReusesItsOwnFolderAndKeepsWhatTheUserAddedSince) {
  const fs::path dir = loom::test::test_dir(), out = dir / "run";
  const std::string scene = write_scene(dir);
  ASSERT_EQ(run_loom("run " + scene + " --frames 5 --out " + out.string()).code, 0);
  write(out / "frames" / "frame_00009.obj", "mine");
  write(out / "pc2" / "extra.txt", "mine");
  const auto r = run_loom("run " + scene + " --frames 2 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00005.obj"));
  EXPECT_EQ(slurp(out / "frames" / "frame_00009.obj"), "mine");
  EXPECT_EQ(slurp(out / "pc2" / "extra.txt"), "mine");
  EXPECT_EQ(nlohmann::json::parse(slurp(out / "summary.json"))["frames"], 2);
}

TEST(OutputFolder, NeverWritesThroughALink) {
  const fs::path dir = loom::test::test_dir(), out = dir / "run", victim = dir / "victim.txt";
  const std::string scene = write_scene(dir);
  ASSERT_EQ(run_loom("run " + scene + " --frames 1 --out " + out.string()).code, 0);
  write(victim, "precious");
  // Links planted where the next run writes (a listed file, and one it has not written yet).
  fs::remove(out / "stats.csv");
  fs::create_symlink(victim, out / "stats.csv.partial");
  fs::create_symlink(victim, out / "frames" / "frame_00003.obj");
  const auto r = run_loom("run " + scene + " --frames 3 --out " + out.string());
  EXPECT_EQ(slurp(victim), "precious");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("symbolic link"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("frame_00003.obj"), std::string::npos) << r.err;
}

TEST(OutputFolder, AForgedManifestNeverDeletesThroughALink) {
  // A manifest that lists a file behind a link inside the folder: the next run deletes its own listed files
  // but never follows the link to a file outside.
  const fs::path dir = loom::test::test_dir(), out = dir / "mine", outside = dir / "outside";
  const std::string scene = write_scene(dir);
  ASSERT_EQ(run_loom("run " + scene + " --frames 1 --out " + out.string()).code, 0);
  write(outside / "a.txt", "user data outside");
  fs::create_symlink(outside, out / "frames" / "x");
  {
    std::ofstream m(out / ".loom-manifest", std::ios::app);
    m << "frames/x/a.txt\n";
  }
  const auto r = run_loom("run " + scene + " --frames 1 --out " + out.string());
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(slurp(outside / "a.txt"), "user data outside");
}

TEST(OutputFolder, SceneNameNeverBecomesAPath) {
  const fs::path dir = loom::test::test_dir(), target = dir / "target";
  const std::string scene = write_scene(dir);
  write(target / "checkpoint" / "checkpoint.bin", "x");
  write(target / "pc2" / "a.pc2", "x");
  write(target / "frames" / "frame_00001.obj", "x");
  for (const std::string& name : std::vector<std::string>{target.string(), "../../x", "a/b"}) {
    // No --out: the default folder out/<name> would be the name itself; run from the scratch folder.
    const std::string cmd = "cd " + dir.string() + " && " + LOOM_BINARY + " run " + scene +
                            " --frames 1 --set 'name=" + name + "' >" + (dir / "o.txt").string() + " 2>" +
                            (dir / "e.txt").string();
    const int status = std::system(cmd.c_str());
    EXPECT_EQ(WEXITSTATUS(status), 1) << name;
    EXPECT_NE(slurp(dir / "e.txt").find("name"), std::string::npos) << slurp(dir / "e.txt");
    EXPECT_NE(slurp(dir / "e.txt").find("plain file name"), std::string::npos) << slurp(dir / "e.txt");
  }
  EXPECT_TRUE(fs::exists(target / "checkpoint" / "checkpoint.bin"));
  EXPECT_TRUE(fs::exists(target / "pc2" / "a.pc2"));
  EXPECT_TRUE(fs::exists(target / "frames" / "frame_00001.obj"));
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(OutputFolder, EmptyPathsAreErrorsNotDefaults) {
  const fs::path dir = loom::test::test_dir();
  const std::string scene = write_scene(dir);
  for (const std::string& args :
       std::vector<std::string>{"run --resume ''", "run " + scene + " --out ''", "run ''"}) {
    const auto r = run_loom(args);
    EXPECT_EQ(r.code, 2) << args;
    EXPECT_NE(r.err.find("empty"), std::string::npos) << args << ": " << r.err;
  }
}

TEST(OutputFolder, FrameNamesPastNinetyNineThousandKeepTheirOrder) {
  const fs::path dir = loom::test::test_dir(), out = dir / "out";
  std::string text = kScene;
  text =
      with(text, "\"output\": {\"formats\": [\"obj\", \"pc2\", \"gltf\"]}", "\"output\": {\"every\": 50000}");
  text = with(text, "\"nodes\": [5, 5]", "\"nodes\": [2, 2]");
  text = with(text, "\"substeps\": 4", "\"substeps\": 1");
  // At rest (no gravity, no pins): 100000 cheap frames.
  text = with(text, "\"duration\": 0.1,", "\"duration\": 0.1, \"gravity\": [0, 0, 0],");
  text = with(text, "\"pins\": [{\"grid\": [0, 0]}, {\"grid\": [-1, 0]}]", "\"pins\": []");
  const std::string scene = write_scene(dir, text);
  const auto r = run_loom("run " + scene + " --frames 100000 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(out / "frames")) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"frame_000000.obj", "frame_050000.obj", "frame_100000.obj"}));
}

TEST(Resources, MemoryIsEstimatedBeforeAllocating) {
  const fs::path dir = loom::test::test_dir();
  const std::string scene = write_scene(dir);
  // 1 GB allowed: a 1000 x 1000 grid (1e6 vertices) is refused with the figure and the field.
  const std::string cmd = std::string("LOOM_MEMORY_LIMIT=1000000000 ") + LOOM_BINARY + " run " + scene +
                          " --set 'cloths[0].mesh.nodes=[1000,1000]' --set 'cloths[0].pins=[]' --out " +
                          (dir / "out").string() + " 2>" + (dir / "e.txt").string();
  EXPECT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 1);
  const std::string err = slurp(dir / "e.txt");
  EXPECT_NE(err.find(scene), std::string::npos) << err;
  EXPECT_NE(err.find("cloths[0].mesh"), std::string::npos) << err;
  EXPECT_NE(err.find("GB of memory"), std::string::npos) << err;
  EXPECT_NE(err.find("1 GB (set by LOOM_MEMORY_LIMIT) is available"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "out"));
  // The documented largest grid, 4096 x 4096, within the same 1 GB.
  const std::string big = std::string("LOOM_MEMORY_LIMIT=1000000000 ") + LOOM_BINARY + " run " + scene +
                          " --set 'cloths[0].mesh.nodes=[4096,4096]' --set 'cloths[0].pins=[]' --out " +
                          (dir / "out").string() + " 2>" + (dir / "e.txt").string();
  EXPECT_EQ(WEXITSTATUS(std::system(big.c_str())), 1);
  EXPECT_NE(slurp(dir / "e.txt").find("of memory"), std::string::npos) << slurp(dir / "e.txt");
}

// A malformed LOOM_MEMORY_LIMIT is a bad command line (exit 2) naming the variable, never ignored.
TEST(Resources, AMalformedMemoryLimitIsRefusedByName) {
  const fs::path dir = loom::test::test_dir();
  const std::string scene = write_scene(dir);
  for (const std::string value : {"abc", "-1", "1.5", "1e999", "18446744073709551616", "0", "", " 5"}) {
    const std::string cmd = "LOOM_MEMORY_LIMIT='" + value + "' " + LOOM_BINARY + " run " + scene +
                            " --frames 1 --out " + (dir / "out").string() + " 2>" + (dir / "e.txt").string();
    EXPECT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 2) << value;
    const std::string err = slurp(dir / "e.txt");
    EXPECT_NE(err.find("LOOM_MEMORY_LIMIT: must be a whole number of bytes"), std::string::npos) << err;
    EXPECT_NE(err.find("(got '" + value + "')"), std::string::npos) << err;
    EXPECT_FALSE(fs::exists(dir / "out")) << value;
  }
}

TEST(Resources, ThreadsAreCappedAtTheMachine) {
  const fs::path dir = loom::test::test_dir();
  const std::string scene = write_scene(dir);
  const auto r = run_loom("run " + scene + " --frames 1 --threads 2000 --out " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("capped"), std::string::npos) << r.err;
  const auto j = nlohmann::json::parse(slurp(dir / "out" / "summary.json"));
  EXPECT_LE(j["threads"].get<int>(), 256);
  EXPECT_GE(j["threads"].get<int>(), 1);
}

TEST(Resources, ScenesThatAreNotFilesAreRefusedWithoutReading) {
  const fs::path dir = loom::test::test_dir();
  for (const std::string& s : {dir.string(), std::string("/dev/zero")}) {
    const auto r = run_loom("run " + s + " --out " + (dir / "out").string());
    EXPECT_EQ(r.code, 1) << s;
    EXPECT_NE(r.err.find(s), std::string::npos) << r.err;
    EXPECT_TRUE(r.err.find("is a folder") != std::string::npos ||
                r.err.find("not a regular file") != std::string::npos)
        << r.err;
  }
}

// A manifest line longer than any path (here 64 MB of NUL bytes after a valid header, sparse on disk) is
// refused when it passes the bound, not read whole; nothing in the folder changes.
TEST(OutputFolder, AManifestOfNulBytesIsRefusedWithoutReadingItWhole) {
  const fs::path dir = loom::test::test_dir(), out = dir / "mine";
  const std::string scene = write_scene(dir);
  ASSERT_EQ(run_loom("run " + scene + " --frames 1 --out " + out.string()).code, 0);
  std::string header;
  {
    std::ifstream m(out / ".loom-manifest");
    std::getline(m, header);
  }
  {
    std::ofstream m(out / ".loom-manifest", std::ios::trunc);
    m << header << "\n";
  }
  fs::resize_file(out / ".loom-manifest", header.size() + 1 + (64u << 20));
  const auto r = run_loom("run " + scene + " --frames 1 --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(".loom-manifest: line 2: longer than"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_00001.obj")) << "a refused run deleted a listed file";
}

// A refused --out leaves no folder behind, the parents it had to make included (a name too long for the
// file system fails after the folders above it were made).
TEST(OutputFolder, ARefusedOutLeavesNoParentFolderItMade) {
  const fs::path dir = loom::test::test_dir();
  const std::string scene = write_scene(dir);
  const fs::path out = dir / "made" / "deeper" / std::string(300, 'x');
  const auto r = run_loom("run " + scene + " --frames 1 --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("cannot create output folder"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "made"));
}

TEST(Nan, NonFiniteStartIsNamedAndNothingIsWritten) {
  const fs::path dir = loom::test::test_dir(), out = dir / "out";
  const std::string scene = write_scene(dir);
  const auto r =
      run_loom("run " + scene + " --frames 2 --set 'cloths[0].velocity=[1e200,0,0]' --out " + out.string());
  // A start speed whose energy overflows is refused when the scene is read (at most 1000 m/s).
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("cloths[0].velocity"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out / "summary.json"));
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00000.obj"));
}

// --- Checkpoints trusted only as far as they prove.

struct CheckpointRun {
  fs::path dir, out;
  std::string scene;
};

CheckpointRun checkpointed(const std::string& text = kScene) {
  CheckpointRun c;
  c.dir = loom::test::test_dir();
  c.out = c.dir / "out";
  c.scene = write_scene(c.dir, text);
  const auto r = run_loom("run " + c.scene + " --frames 4 --checkpoint-every 2 --out " + c.out.string());
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(c.out / "checkpoint" / "checkpoint.bin"));
  return c;
}

// The refusal names `what` and changes no output of the run.
void expect_refused(const CheckpointRun& c, const std::string& what, const std::string& problem) {
  const std::string summary = slurp(c.out / "summary.json"), stats = slurp(c.out / "stats.csv");
  const auto r = run_loom("run --resume " + c.out.string() + " --frames 6");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(problem), std::string::npos) << r.err;
  EXPECT_EQ(slurp(c.out / "summary.json"), summary);
  EXPECT_EQ(slurp(c.out / "stats.csv"), stats);
}

std::string read_bytes(const fs::path& p) { return slurp(p); }
void write_bytes(const fs::path& p, const std::string& s) {
  std::ofstream(p, std::ios::binary | std::ios::trunc) << s;
}

TEST(CheckpointTrust, FlippedBitIsRefusedByChecksum) {
  const CheckpointRun c = checkpointed();
  const fs::path f = c.out / "checkpoint" / "checkpoint.bin";
  std::string b = read_bytes(f);
  b[b.size() / 2] ^= 0x04;
  write_bytes(f, b);
  expect_refused(c, f.string(), "checksum");
}

TEST(CheckpointTrust, EditedFrameNumberIsRefused) {
  const CheckpointRun c = checkpointed();
  const fs::path f = c.out / "checkpoint" / "checkpoint.bin";
  std::string b = read_bytes(f);
  const size_t at = b.find("\"frame\":");
  ASSERT_NE(at, std::string::npos);
  b[at + 8] = b[at + 8] == '1' ? '3' : '1';
  write_bytes(f, b);
  expect_refused(c, f.string(), "checksum");
}

TEST(CheckpointTrust, OldFormatIsRefusedByVersion) {
  const CheckpointRun c = checkpointed();
  const fs::path f = c.out / "checkpoint" / "checkpoint.bin";
  std::string b = read_bytes(f);
  b[8] = '1';
  write_bytes(f, b);
  expect_refused(c, f.string(), "checkpoint format 1");
}

TEST(CheckpointTrust, CheckpointOfAnotherFolderIsRefused) {
  const CheckpointRun c = checkpointed();
  const fs::path other = c.dir / "other";
  ASSERT_EQ(run_loom("run " + c.scene + " --frames 3 --checkpoint-every 1 --out " + other.string()).code, 0);
  fs::copy_file(other / "checkpoint" / "checkpoint.bin", c.out / "checkpoint" / "checkpoint.bin",
                fs::copy_options::overwrite_existing);
  expect_refused(c, "checkpoint.bin", "another run's output folder");
}

TEST(CheckpointTrust, ChangedMeshFileIsRefusedByName) {
  CheckpointRun c;
  c.dir = loom::test::test_dir();
  write(c.dir / "cloth.obj", "v 0 1 0\nv 1 1 0\nv 0 1 1\nv 1 1 1\nf 1 2 4\nf 1 4 3\n");
  std::string text = kScene;
  text = with(text, "{\"type\": \"grid\", \"size\": [1, 1], \"nodes\": [5, 5], \"origin\": [-0.5, 1, -0.5]}",
              "{\"type\": \"obj\", \"path\": \"cloth.obj\"}");
  text = with(text, "\"pins\": [{\"grid\": [0, 0]}, {\"grid\": [-1, 0]}]", "\"pins\": [{\"vertex\": 0}]");
  c = checkpointed(text);
  write(c.dir / "cloth.obj", "v 0 1 0\nv 1 1 0\nv 0 1 1\nv 1 1 1.01\nf 1 2 4\nf 1 4 3\n");  // a 1 cm nudge
  expect_refused(c, (c.dir / "cloth.obj").string(), "changed since the checkpoint");
}

TEST(CheckpointTrust, ChangedFrameLogIsRefused) {
  const CheckpointRun c = checkpointed();
  const fs::path f = c.out / "checkpoint" / "frames.bin";
  std::string b = read_bytes(f);
  ASSERT_GT(b.size(), 64u);
  b[40] ^= 0x01;
  write_bytes(f, b);
  expect_refused(c, f.string(), "frame log changed");
}

TEST(CheckpointTrust, ResumeWorksFromAnotherWorkingFolder) {
  // The scene given by a relative path; the resume runs from elsewhere.
  const fs::path dir = loom::test::test_dir();
  write_scene(dir);
  const std::string run = "cd " + dir.string() + " && " + LOOM_BINARY +
                          " run scene.json --frames 4 --checkpoint-every 2 --out out >/dev/null 2>&1";
  ASSERT_EQ(WEXITSTATUS(std::system(run.c_str())), 0);
  const std::string resume = "cd / && " + std::string(LOOM_BINARY) + " run --resume " +
                             (dir / "out").string() + " --frames 6 >/dev/null 2>" + (dir / "e.txt").string();
  ASSERT_EQ(WEXITSTATUS(std::system(resume.c_str())), 0) << slurp(dir / "e.txt");
  const auto j = nlohmann::json::parse(slurp(dir / "out" / "summary.json"));
  EXPECT_TRUE(j["completed"].get<bool>());
  EXPECT_EQ(j["frames"], 6);
}

TEST(CheckpointTrust, TruncatedFrameLogIsRefusedWhereTheCheckpointNeedsIt) {
  // frames.bin holds frames 0-4; the checkpoint (frame 2) needs the first 3. Cut 7 bytes off the end: only
  // frame 4 is lost, which the resume simulates again (exit 0, complete). Cut 7 bytes into frame 2: refused.
  {
    const CheckpointRun c = checkpointed();
    const fs::path f = c.out / "checkpoint" / "frames.bin";
    const std::string b = read_bytes(f);
    ASSERT_EQ(b.size() % 5, 0u);
    write_bytes(f, b.substr(0, b.size() - 7));
    const auto r = run_loom("run --resume " + c.out.string() + " --frames 6");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(nlohmann::json::parse(slurp(c.out / "summary.json"))["completed"].get<bool>());
  }
  const CheckpointRun c = checkpointed();
  const fs::path f = c.out / "checkpoint" / "frames.bin";
  const std::string b = read_bytes(f);
  write_bytes(f, b.substr(0, b.size() / 5 * 3 - 7));
  expect_refused(c, f.string(), "frame log is shorter than the checkpoint says (3 frames)");
}

TEST(CheckpointTrust, FewerFramesThanTheCheckpointAreRefused) {
  const CheckpointRun c = checkpointed();
  const std::string summary = slurp(c.out / "summary.json");
  const auto r = run_loom("run --resume " + c.out.string() + " --frames 1");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("--frames"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1 is below the checkpoint's frame 2"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(c.out / "summary.json"), summary);
  // As many frames as the checkpoint holds finishes the outputs without a step.
  const auto same = run_loom("run --resume " + c.out.string() + " --frames 2");
  EXPECT_EQ(same.code, 0) << same.err;
  EXPECT_EQ(nlohmann::json::parse(slurp(c.out / "summary.json"))["frames"], 2);
}

// --- The output folder is never reached through a link, whoever writes it.

TEST(OutputFolder, AnOutputFolderThatIsALinkIsRefused) {
  const fs::path dir = loom::test::test_dir(), real = dir / "real", link = dir / "link";
  const std::string scene = write_scene(dir);
  write(real / "notes.txt", "user data");
  fs::create_directory_symlink(real, link);
  for (const std::string& out : {link.string(), link.string() + "/"}) {
    const auto r = run_loom("run " + scene + " --frames 1 --overwrite --out " + out);
    EXPECT_EQ(r.code, 1) << out << ": " << r.err;
    EXPECT_NE(r.err.find(link.string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("is a symbolic link"), std::string::npos) << r.err;
  }
  EXPECT_EQ(slurp(real / "notes.txt"), "user data");
  EXPECT_EQ(std::distance(fs::directory_iterator(real), fs::directory_iterator()), 1);
}

// `loom compare`, `loom bench accuracy`, `loom bench realtime` and `loom fabric-test` own their --out folder
// as `loom run` does: a non-empty folder Loom did not write is refused (before any run) unless --overwrite,
// and a link is refused even then.
TEST(OutputFolder, EveryCommandOwnsItsOutputFolder) {
  const fs::path dir = loom::test::test_dir(), foreign = dir / "foreign", link = dir / "link";
  const std::string scene = write_scene(dir);
  write(foreign / "compare.csv", "user data");
  write(foreign / "accuracy.csv", "user data");
  write(foreign / "notes.txt", "user data");
  fs::create_directory_symlink(foreign, link);
  const std::vector<std::string> commands = {"fabric-test catenary --resolution 8",
                                             "compare " + scene + " --frames 1", "bench accuracy --quick",
                                             "bench realtime --quick"};
  for (const std::string& cmd : commands) {
    auto r = run_loom(cmd + " --out " + foreign.string());
    if (r.err.find("unknown command") != std::string::npos) continue;  // a build without Bullet
    EXPECT_EQ(r.code, 1) << cmd << ": " << r.err;
    EXPECT_NE(r.err.find(foreign.string()), std::string::npos) << cmd << ": " << r.err;
    EXPECT_NE(r.err.find("was not written by loom"), std::string::npos) << cmd << ": " << r.err;
    r = run_loom(cmd + " --overwrite --out " + link.string());
    EXPECT_EQ(r.code, 1) << cmd << ": " << r.err;
    EXPECT_NE(r.err.find("is a symbolic link"), std::string::npos) << cmd << ": " << r.err;
  }
  for (const char* f : {"compare.csv", "accuracy.csv", "notes.txt"})
    EXPECT_EQ(slurp(foreign / f), "user data") << f;
}

TEST(OutputFolder, CompareWritesItsFilesThroughTheManifest) {
  const fs::path dir = loom::test::test_dir(), out = dir / "cmp";
  const std::string scene = write_scene(dir);
  auto r = run_loom("compare " + scene + " --frames 1 --out " + out.string());
  if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "no Bullet in this build";
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string manifest = slurp(out / ".loom-manifest");
  EXPECT_NE(manifest.find("\ncompare.csv\n"), std::string::npos) << manifest;
  EXPECT_NE(manifest.find("\ncompare.json\n"), std::string::npos) << manifest;
  write(out / "mine.txt", "user data");  // added by the user since: kept by the next run
  r = run_loom("compare " + scene + " --frames 1 --out " + out.string());
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(slurp(out / "mine.txt"), "user data");
  EXPECT_TRUE(fs::exists(out / "compare.csv"));
}

}  // namespace
