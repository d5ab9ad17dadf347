// `loom bench accuracy --quick` end to end: the CSV has exactly the columns, every registered Loom
// solver and both Bullet systems appear, the reference check is reported, bad options exit 2.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "CliRunner.h"
#include "TestDir.h"

namespace {

namespace fs = std::filesystem;

using loom::test::slurp;
using Result = loom::test::CliResult;

// The runner already gives every test its own folder; `dir` is where the test keeps its outputs.
Result run(const std::string& args, const fs::path&) { return loom::test::run_loom(args); }

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, sep)) v.push_back(item);
  return v;
}

// The registered solvers, as `loom run --help` lists them ("Solvers: a, b, c").
std::set<std::string> registered_solvers(const fs::path& dir) {
  const Result r = run("run --help", dir);
  const size_t at = r.out.find("Solvers: ");
  std::set<std::string> names;
  if (at == std::string::npos) return names;
  const std::string line = r.out.substr(at + 9, r.out.find('\n', at) - at - 9);
  for (std::string n : split(line, ',')) {
    n.erase(0, n.find_first_not_of(' '));
    if (!n.empty()) names.insert(n);
  }
  return names;
}

// Thread counts past the machine's are capped at its hardware threads with a warning (as loom run does), and
// a count the cap makes twice runs once: the rows state the threads that ran.
TEST(BenchAccuracy, ThreadsPastTheMachineAreCapped) {
  const auto dir = loom::test::test_dir() / "thr";
  const auto r = loom::test::run_loom(
      "bench accuracy --quick --sizes 3 --methods verlet --threads 1,4096 --out " + dir.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("--threads 4096 capped at the"), std::string::npos) << r.err;
  const std::string csv = loom::test::slurp(dir / "accuracy.csv");
  EXPECT_EQ(csv.find(",4096,"), std::string::npos) << csv;
}

}  // namespace

TEST(BenchAccuracy, QuickRunWritesTheCsvWithEveryMethodAndTheReferenceCheck) {
  const fs::path dir = loom::test::test_dir() / "out";
  fs::remove_all(dir);
  const fs::path out = dir / "out";
  const Result r = run("bench accuracy --quick --out " + out.string(), dir);
  ASSERT_EQ(r.code, 0) << r.out << r.err;

  std::ifstream csv(out / "accuracy.csv");
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  EXPECT_EQ(
      line,
      "system,method,size,config,threads,ms_per_frame,rms_error_max,rms_error_end,max_strain,mean_strain,"
      "energy_drift,diverged");
  std::map<std::string, int> rows_per_method;
  std::set<std::string> systems;
  while (std::getline(csv, line)) {
    const auto f = split(line, ',');
    ASSERT_EQ(f.size(), 12u) << line;
    systems.insert(f[0]);
    ++rows_per_method[f[1]];
    EXPECT_TRUE(f[11] == "0" || f[11] == "1") << line;
    // No table holds "nan" or "inf": a figure a diverged run has not is an empty field.
    EXPECT_EQ(line.find("nan"), std::string::npos) << line;
    EXPECT_EQ(line.find("inf"), std::string::npos) << line;
    for (int k : {5, 6, 7, 8, 9, 10}) {
      if (f[k].empty()) {
        EXPECT_EQ(f[11], "1") << "an empty figure in a row that did not diverge: " << line;
      }
    }
    // Time is measured for every run that did not diverge at 1 thread (thread counts give identical results).
    if (!f[5].empty()) {
      EXPECT_GE(std::stod(f[5]), 0.0) << line;
    }
    if (f[11] == "0") {
      // Finite rows carry finite errors (m) and strains.
      for (int k : {6, 7, 8, 9, 10}) EXPECT_TRUE(std::isfinite(std::stod(f[k]))) << line;
      EXPECT_LE(std::stod(f[7]), std::stod(f[6]) + 1e-15) << "end error above the max: " << line;
    }
  }
  EXPECT_EQ(systems, (std::set<std::string>{"loom", "bullet_classic", "bullet_deformable"}));
  const std::set<std::string> solvers = registered_solvers(dir);
  ASSERT_FALSE(solvers.empty());
  for (const std::string& s : solvers) EXPECT_GT(rows_per_method[s], 0) << "solver " << s << " missing";
  EXPECT_GT(rows_per_method["bullet_classic"], 0);
  EXPECT_GT(rows_per_method["bullet_deformable"], 0);

  // The reference check: printed, and in reference_check.csv with the ratio to the smallest error.
  EXPECT_NE(r.out.find("reference check N=8"), std::string::npos) << r.out;
  const auto ref = split(slurp(out / "reference_check.csv"), '\n');
  ASSERT_GE(ref.size(), 2u);
  EXPECT_EQ(ref[0], "size,ref_substeps,check_substeps,ref_change,smallest_error,ratio,passed,ref_max_strain");
  const auto f = split(ref[1], ',');
  ASSERT_EQ(f.size(), 8u);
  EXPECT_EQ(f[0], "8");
  EXPECT_GT(std::stod(f[4]), 0.0);
  // The CSV holds 6 significant digits (relative rounding up to 5e-6 each): the quotient of two printed
  // values matches the printed ratio to 1.5e-5.
  EXPECT_NEAR(std::stod(f[5]), std::stod(f[3]) / std::stod(f[4]), 2e-5 * std::stod(f[5]) + 1e-12);
  EXPECT_EQ(f[6], std::stod(f[5]) < 0.01 ? "1" : "0");
  EXPECT_GT(std::stod(f[7]), 0.0);  // the hanging cloth stretches
  EXPECT_LT(std::stod(f[7]), 0.5);
}

TEST(BenchAccuracy, RepeatsKeepOneRowPerThreadCountWithTheSameResults) {
  // --repeats 3: each row runs three times (1 and 2 threads interleaved); one row per thread count is
  // written, and no repeat reports other results (runs are bit-identical).
  const fs::path dir = loom::test::test_dir() / "repeats";
  fs::remove_all(dir);
  const fs::path out = dir / "out";
  const Result r =
      run("bench accuracy --quick --methods xpbd,projective --repeats 3 --out " + out.string(), dir);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_EQ(r.out.find("results differ"), std::string::npos) << r.out;
  std::ifstream csv(out / "accuracy.csv");
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  std::map<std::string, int> rows;
  while (std::getline(csv, line)) {
    const auto f = split(line, ',');
    ASSERT_EQ(f.size(), 12u) << line;
    ++rows[f[1] + " " + f[3] + " threads=" + f[4]];
    EXPECT_GE(std::stod(f[5]), 0.0) << line;
  }
  ASSERT_EQ(rows.size(), 4u);  // xpbd and projective, one configuration each (--quick), 1 and 2 threads
  for (const auto& [key, n] : rows) EXPECT_EQ(n, 1) << key;
}

TEST(BenchAccuracy, BadOptionsExitWithTwo) {
  const fs::path dir = loom::test::test_dir() / "bad";
  EXPECT_EQ(run("bench accuracy --repeats 0", dir).code, 2);
  EXPECT_EQ(run("bench accuracy --repeats 2,3", dir).code, 2);
  EXPECT_EQ(run("bench accuracy --sizes 2,x", dir).code, 2);
  EXPECT_EQ(run("bench accuracy --bogus", dir).code, 2);
  EXPECT_EQ(run("bench nothing", dir).code, 2);
  EXPECT_EQ(run("bench --help", dir).code, 0);
}

TEST(BenchAccuracy, UnknownMethodIsAnErrorNotAnEmptyPass) {
  const fs::path dir = loom::test::test_dir();
  const Result r = run("bench accuracy --quick --methods xpbd,nosuch --out " + (dir / "out").string(), dir);
  if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "built without the Bullet bridge";
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("--methods"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("'nosuch'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out" / "accuracy.csv"));
  EXPECT_EQ(r.out.find("PASSED"), std::string::npos) << r.out;
}

// A selection that matches nothing (a label no configuration has, an empty list) measures nothing: an error
// naming the option, never an empty table that passes its reference check.
TEST(BenchAccuracy, EmptySelectionIsAnErrorNotAnEmptyPass) {
  const fs::path dir = loom::test::test_dir();
  const std::string out = " --out " + (dir / "out").string();
  Result r = run("bench accuracy --quick --sizes 4 --methods verlet --configs nosuchlabel" + out, dir);
  if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "built without the Bullet bridge";
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("--methods/--configs: selects no configuration"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out" / "accuracy.csv"));
  EXPECT_EQ(r.out.find("PASSED"), std::string::npos) << r.out;
  // Refused before the reference run (the expensive part) and before the output folder exists.
  EXPECT_EQ(r.out.find("reference:"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "out")) << "a refused selection created its output folder";
  // With several sizes, the first size that selects nothing is named before any size runs.
  r = run("bench accuracy --quick --sizes 4,8 --methods verlet --configs substeps=999999" + out, dir);
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("selects no configuration at N=4"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("reference:"), std::string::npos) << r.out;
  // Without --methods: --configs names Loom configurations, so a text no Loom label holds selects nothing
  // (the Bullet rows and the static scenes' rows beside them do not count).
  r = run("bench accuracy --quick --sizes 4 --configs zzzz" + out, dir);
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("selects no configuration at N=4 (no label contains 'zzzz')"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
  for (const char* empty : {"--methods ''", "--methods ,", "--configs ''"}) {
    r = run(std::string("bench accuracy --quick ") + empty + out, dir);
    EXPECT_EQ(r.code, 2) << empty << ": " << r.err;
    EXPECT_NE(r.err.find(std::string(empty).substr(0, 9)), std::string::npos) << r.err;
  }
}
