// `loom body`: MakeHuman's base mesh fitted to a CMU clip's skeleton with a skinned cape, end to end, and its
// bad input (exit 2 for the command line, 1 for a bad file, each naming what is wrong).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "CliRunner.h"

namespace {

const std::string kData = LOOM_TEST_DATA;
const std::string kMesh = kData + "/body/human.zae", kClip = kData + "/mocap/01_01.bvh";

#define SKIP_WITHOUT_BODY(r)                                       \
  if ((r).err.find("unknown command 'body'") != std::string::npos) \
  GTEST_SKIP() << "built without loom::characters"

// The value after `key=` in a line of key=value pairs.
double field(const std::string& line, const std::string& key) {
  const size_t at = line.find(key + "=");
  EXPECT_NE(at, std::string::npos) << key << " in " << line;
  return at == std::string::npos ? NAN : std::atof(line.c_str() + at + key.size() + 1);
}

}  // namespace

TEST(BodyCli, FitsTheBodyAndKeepsTheCapesConstraints) {
  const loom::test::CliResult r = loom::test::run_loom("body " + kMesh + " " + kClip + " --seconds 1");
  SKIP_WITHOUT_BODY(r);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(field(r.out, "frames"), 30);
  EXPECT_EQ(field(r.out, "joints"), 38);
  EXPECT_GT(field(r.out, "vertices"), 13000);
  // The body's capsules collide last and may push the cape past its max distance by less than the contact
  // thickness (5 mm); never behind the backstop.
  EXPECT_LE(field(r.out, "worst_over_max_distance"), 0.005);
  EXPECT_LE(field(r.out, "worst_behind_backstop"), 1e-12);
  EXPECT_GT(field(r.out, "hem_motion"), 0.01);
  EXPECT_LE(field(r.out, "deepest_in_body_capsules"), 0.005);  // the contact thickness
}

TEST(BodyCli, RefusesBadInputNamingIt) {
  const auto dir = loom::test::test_dir();
  const auto bvh = dir / "spine.bvh";
  std::ofstream(bvh) << "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition "
                        "Zrotation Xrotation Yrotation\n JOINT Spine\n {\n  OFFSET 0 10 0\n  CHANNELS 3 "
                        "Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 10 0\n  }\n }\n}\n"
                        "MOTION\nFrames: 4\nFrame Time: 0.02\n0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0 0\n"
                        "0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0 0\n";
  // A clip of one frame: it lasts 0 s, less than the one 1/30 s frame a measurement needs.
  const auto one = dir / "one.bvh";
  {
    std::ifstream in(kClip);
    std::ofstream out(one);
    std::string line;
    while (std::getline(in, line) && line.rfind("Frame Time:", 0) != 0)
      out << (line.rfind("Frames:", 0) == 0 ? std::string("Frames: 1") : line) << "\n";
    out << line << "\n";
    std::getline(in, line);
    out << line << "\n";
  }
  struct Case {
    std::string args;
    int code;
    std::string message;
  };
  const std::vector<Case> cases = {
      {"body", 2, "needs MESH and CLIP.bvh"},
      {"body " + kMesh, 2, "needs MESH and CLIP.bvh"},
      {"body " + kMesh + " " + kClip + " --seconds nan", 2, "--seconds"},
      {"body " + kMesh + " " + kClip + " --seconds -1", 2, "--seconds"},
      {"body " + kMesh + " " + kClip + " --seconds 0", 2, "--seconds"},
      {"body " + kMesh + " " + kClip + " --seconds 0.03", 2, "--seconds"},
      {"body " + kMesh + " " + one.string(), 1, "CLIP: lasts 0 s, less than one frame"},
      {"body " + kClip + " " + kClip, 2, "is a BVH clip, not a body mesh"},
      {"body " + kMesh + " " + kClip + " --bogus", 2, "unknown option '--bogus'"},
      {"body " + kMesh + " " + bvh.string(), 1, "joints: no joint 'LeftUpLeg'"},
      {"body " + (dir / "missing.zae").string() + " " + kClip, 1, "missing.zae"},
  };
  for (const Case& c : cases) {
    const loom::test::CliResult r = loom::test::run_loom(c.args);
    SKIP_WITHOUT_BODY(r);
    EXPECT_EQ(r.code, c.code) << c.args << ": " << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.args << ": " << r.err;
  }
}

// --image in a folder reached through a symbolic link whose target is missing: refused before the clip is
// read, naming the link and its target (not a folder that "does not exist").
TEST(BodyCli, AnImageFolderThroughADanglingLinkIsNamed) {
  const auto dir = loom::test::test_dir();
  std::filesystem::remove(dir / "imgl");
  std::filesystem::create_directory_symlink("../no_such_folder_here", dir / "imgl");
  const loom::test::CliResult r =
      loom::test::run_loom("body " + kMesh + " " + kClip + " --image " + (dir / "imgl" / "new.png").string());
  SKIP_WITHOUT_BODY(r);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("--image: its folder is reached through the symbolic link " + (dir / "imgl").string() +
                       " to '../no_such_folder_here', which does not exist"),
            std::string::npos)
      << r.err;
}
