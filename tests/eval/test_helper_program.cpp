// Helper programs (HelperProgram.h) run without a shell: what would be a command to a shell or to gnuplot
// reaches the program as text, and a gnuplot string holds any text as one literal.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "TestDir.h"
#include "loom/eval/HelperProgram.h"
#include "loom/eval/OutputFolder.h"

namespace loom::test {
namespace {

namespace fs = std::filesystem;

TEST(HelperProgram, ArgumentsReachTheProgramAsTheyAreNeverThroughAShell) {
  const fs::path dir = test_dir();
  std::string out;
  const std::string hostile = "a'b\"c;touch PWNED;$(touch PWNED2)`touch PWNED3` |&>";
  EXPECT_EQ(eval::run_program({"echo", hostile}, dir, &out), 0);
  EXPECT_EQ(out, hostile + "\n");
  for (const char* f : {"PWNED", "PWNED2", "PWNED3"}) EXPECT_FALSE(fs::exists(dir / f)) << f;
}

TEST(HelperProgram, RunsInTheGivenFolderAndReportsTheExitStatus) {
  const fs::path dir = test_dir();
  std::string out;
  EXPECT_EQ(eval::run_program({"pwd"}, dir, &out), 0);
  EXPECT_EQ(fs::path(out.substr(0, out.size() - 1)), fs::canonical(dir));
  EXPECT_EQ(eval::run_program({"sh", "-c", "exit 7"}, dir, nullptr), 7);
  EXPECT_EQ(eval::run_program({"sh", "-c", "kill -9 $$"}, dir, nullptr), -1);  // died by a signal
  EXPECT_EQ(eval::run_program({"no-such-program-of-loom"}, dir, nullptr), 127);
  EXPECT_FALSE(eval::program_on_path("no-such-program-of-loom"));
  EXPECT_FALSE(eval::program_on_path("../sh"));  // a name, never a path
  EXPECT_TRUE(eval::program_on_path("sh"));
}

TEST(HelperProgram, AGnuplotStringHoldsAnyTextAsOneLiteral) {
  EXPECT_EQ(eval::gnuplot_quote("plain"), "'plain'");
  EXPECT_EQ(eval::gnuplot_quote("it's"), "'it''s'");
  EXPECT_EQ(eval::gnuplot_quote("a'; system(\"touch x\"); '"), "'a''; system(\"touch x\"); '''");
  EXPECT_EQ(eval::gnuplot_quote("line\nbreak\r\x7f"),
            "'line?break?"
            "?'");
}

// A helper runs in the folder open as a descriptor: that folder renamed away and its name replaced by a
// symbolic link to another folder before the helper starts, what it writes by a relative name lands in the
// folder it was given (under its new name), never behind the link. Run by the path instead, it would.
TEST(HelperProgram, AHelperWritesIntoItsOpenFolderNotThroughALinkPlantedAtItsName) {
  const fs::path dir = test_dir();
  fs::create_directories(dir / "private");
  fs::create_directories(dir / "elsewhere");
  const int fd = ::open((dir / "private").c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  fs::rename(dir / "private", dir / "moved");
  fs::create_directory_symlink(dir / "elsewhere", dir / "private");
  EXPECT_EQ(eval::run_program({"/bin/sh", "-c", "echo x > out.txt"}, fd, nullptr), 0);
  ::close(fd);
  EXPECT_TRUE(fs::is_regular_file(dir / "moved" / "out.txt"));
  EXPECT_FALSE(fs::exists(dir / "elsewhere" / "out.txt"));
  EXPECT_EQ(eval::run_program({"/bin/sh", "-c", "echo x > by_path.txt"}, dir / "private", nullptr), 0);
  EXPECT_TRUE(fs::exists(dir / "elsewhere" / "by_path.txt"));  // the hazard the descriptor avoids
}

// The output folder's private folder comes with its descriptor (made by mkdirat on DIR's, opened without
// following a link): swapped for a link after it is made, the helper still writes into it.
TEST(HelperProgram, APrivateFolderSwappedForALinkIsNotFollowed) {
  const fs::path dir = test_dir() / "out", other = test_dir() / "other";
  fs::create_directories(other);
  eval::OutputFolder folder(dir, "--out", false, false, {}, {});
  int fd = -1;
  const fs::path priv = folder.claim_private_folder(".loom-helper-", {"a.txt"}, &fd);
  ASSERT_GE(fd, 0);
  EXPECT_EQ(priv.parent_path(), dir);
  EXPECT_EQ(fs::status(priv).permissions() & fs::perms::all, fs::perms::owner_all);
  fs::rename(priv, dir / "renamed");
  fs::create_directory_symlink(other, priv);
  EXPECT_EQ(eval::run_program({"/bin/sh", "-c", "echo x > a.txt"}, fd, nullptr), 0);
  ::close(fd);
  EXPECT_TRUE(fs::is_regular_file(dir / "renamed" / "a.txt"));
  EXPECT_TRUE(fs::is_empty(other));
}

// gnuplot (when installed) runs in its private folder and reads its data from DIR through "..": the plot
// lands in DIR and the private folder is gone.
TEST(HelperProgram, GnuplotMakesItsPlotFromItsPrivateFolder) {
  if (!eval::program_on_path("gnuplot")) GTEST_SKIP() << "gnuplot is not installed";
  const fs::path dir = test_dir() / "plot";
  eval::OutputFolder folder(dir, "--out", false, false, {}, {});
  std::ofstream(folder.claim("d.dat")) << "0 1\n1 2\n2 0\n";
  const std::string why = eval::gnuplot_png(folder, "p", "set terminal pngcairo size 200,100",
                                            "plot 'd.dat' using 1:2 with lines notitle\n");
  EXPECT_EQ(why, "");
  EXPECT_GT(fs::file_size(dir / "p.png"), 100u);
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_NE(e.path().filename().string().rfind(".loom-helper-", 0), 0u) << e.path();
}

}  // namespace
}  // namespace loom::test
