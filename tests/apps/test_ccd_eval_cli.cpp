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
#include <vector>

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
  // The query type comes from the path: a path naming both types, or neither, is refused saying which.
  const std::filesystem::path both = loom::test::test_dir() / "edge-edge" / "vertex-face-q.csv";
  std::filesystem::create_directories(both.parent_path());
  std::ofstream(both) << "\n";
  const CcdEvalRun two = ccd_eval(both.string());
  EXPECT_EQ(two.code, 1);
  EXPECT_NE(two.err.find("contains both 'vertex-face' and 'edge-edge'"), std::string::npos) << two.err;
  const std::filesystem::path neither = loom::test::test_dir() / "queries.csv";
  std::ofstream(neither) << "\n";
  const CcdEvalRun zero = ccd_eval(neither.string());
  EXPECT_EQ(zero.code, 1);
  EXPECT_NE(zero.err.find("contains neither 'vertex-face' nor 'edge-edge'"), std::string::npos) << zero.err;
}

// Exact means exact: a number with a blank inside ("1 0", which GMP would read as 10) is refused by line,
// and a --scale-exp that would overflow or underflow a coordinate is refused by the option, the file and the
// query's line.
TEST(CcdEvalCli, InexactInputsAreRefusedNeverReadApproximately) {
  const std::filesystem::path dir = loom::test::test_dir() / "vertex-face";
  std::filesystem::create_directories(dir);
  std::ifstream in(kData + "vertex-face/data_0_0.csv");
  std::vector<std::string> rows;
  for (std::string line; rows.size() < 8 && std::getline(in, line);) rows.push_back(line);
  ASSERT_EQ(rows.size(), 8u);
  auto write = [&](const std::string& name, const std::string& first_cell) {
    std::ofstream out(dir / name);
    out << first_cell << rows[0].substr(rows[0].find(',')) << "\n";
    for (size_t i = 1; i < rows.size(); ++i) out << rows[i] << "\n";
    return (dir / name).string();
  };
  const CcdEvalRun blank = ccd_eval(write("blank.csv", "1 0"));
  EXPECT_EQ(blank.code, 1) << blank.err;
  EXPECT_NE(blank.err.find("blank.csv: line 1: '1 0/"), std::string::npos) << blank.err;
  EXPECT_NE(blank.err.find("is not a rational of integers"), std::string::npos) << blank.err;
  std::string big = "1";  // 2^900 in decimal, a double exactly; times 2^200 past the double range
  for (int i = 0; i < 900; ++i) {
    int carry = 0;
    for (auto d = big.rbegin(); d != big.rend(); ++d) {
      const int v = (*d - '0') * 2 + carry;
      *d = static_cast<char>('0' + v % 10);
      carry = v / 10;
    }
    if (carry) big.insert(big.begin(), static_cast<char>('0' + carry));
  }
  const CcdEvalRun over = ccd_eval(write("big.csv", big) + " --scale-exp 200");
  EXPECT_NE(over.code, 0) << over.err;
  EXPECT_NE(over.err.find("big.csv: line 1: --scale-exp 200: a coordinate"), std::string::npos) << over.err;
  EXPECT_NE(over.err.find("overflows or underflows"), std::string::npos) << over.err;
}
