// Helper programs (HelperProgram.h) run without a shell: what would be a command to a shell or to gnuplot
// reaches the program as text, and a gnuplot string holds any text as one literal.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "TestDir.h"
#include "loom/eval/HelperProgram.h"

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

}  // namespace
}  // namespace loom::test
