// `loom ccd-eval`: one output line with the documented fields, exit codes, errors naming the file.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "CliRunner.h"

namespace {

using CcdEvalRun = loom::test::CliResult;

CcdEvalRun ccd_eval(const std::string& args) { return loom::test::run_loom("ccd-eval " + args); }

const std::string kData = std::string(LOOM_TEST_DATA) + "/ccd-sample-queries/unit-tests/";

}  // namespace

TEST(CcdEvalCli, PrintsOneLineWithZeroFalseNegatives) {
  for (const std::string extra : {"", " --scale-exp -10 --translate 5", " --scale-exp 10 --translate 5"}) {
    const CcdEvalRun r =
        ccd_eval(kData + "vertex-face/data_0_0.csv " + kData + "edge-edge/data_0_0.csv" + extra);
    ASSERT_EQ(r.code, 0) << r.err;
    std::smatch m;
    const std::regex line(
        "queries=(\\d+) positives=(\\d+) false_negatives=(\\d+) false_positives=(\\d+) "
        "us_per_query=[0-9.]+\\n");
    ASSERT_TRUE(std::regex_match(r.out, m, line)) << r.out;
    EXPECT_EQ(m[1], "179");  // 125 VF + 54 EE queries
    EXPECT_EQ(m[3], "0") << extra;
  }
}

TEST(CcdEvalCli, ErrorsAndExitCodes) {
  EXPECT_EQ(ccd_eval("").code, 2);
  const CcdEvalRun missing = ccd_eval(kData + "vertex-face/missing.csv");
  EXPECT_EQ(missing.code, 1);
  EXPECT_NE(missing.err.find("missing.csv"), std::string::npos) << missing.err;
  EXPECT_EQ(ccd_eval(kData + "vertex-face/data_0_0.csv --scale-exp x").code, 2);
  EXPECT_EQ(ccd_eval("--help").code, 0);
  // A file without queries measures nothing: refused, not reported as zero false negatives.
  const std::filesystem::path empty = loom::test::test_dir() / "vertex-face" / "empty.csv";
  std::filesystem::create_directories(empty.parent_path());
  std::ofstream(empty) << "\n";
  const CcdEvalRun none = ccd_eval(empty.string());
  EXPECT_EQ(none.code, 1);
  EXPECT_NE(none.err.find("empty.csv: holds no queries"), std::string::npos) << none.err;
}
