// `loom fabric-test` end to end: the --json contract, the report files, and errors.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace {

namespace fs = std::filesystem;

struct Result {
  int code = -1;
  std::string out, err;
};

Result loom(const std::string& args) {
  const fs::path dir = fs::temp_directory_path() / "loom_fabric_cli";
  fs::create_directories(dir);
  const std::string cmd = std::string(LOOM_BINARY) + " " + args + " >" + (dir / "o").string() + " 2>" + (dir / "e").string();
  const int status = std::system(cmd.c_str());
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  };
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(dir / "o"), slurp(dir / "e")};
}

TEST(FabricTestCli, JsonObjectAndReport) {
  const fs::path out = fs::temp_directory_path() / "loom_fabric_cli" / "catenary";
  fs::remove_all(out);
  const Result r = loom("fabric-test catenary --span 0.8 --json --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"test", "material", "model", "resolution", "measured", "theory", "error", "span_m"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["test"], "catenary");
  EXPECT_NEAR(j["theory"].get<double>(), 0.26544, 1e-5);
  EXPECT_LT(std::abs(j["error"].get<double>()), 0.01 * 0.26544);
  EXPECT_TRUE(fs::exists(out / "report.md"));
  EXPECT_TRUE(fs::exists(out / "curve.csv"));
}

TEST(FabricTestCli, TextOutputAndErrors) {
  Result r = loom("fabric-test tensile --model choi_ko --out " + (fs::temp_directory_path() / "loom_fabric_cli" / "t").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("measured"), std::string::npos);
  EXPECT_NE(r.out.find("E100_percent"), std::string::npos);
  r = loom("fabric-test tensile --model fem");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("--model"), std::string::npos) << r.err;
  r = loom("fabric-test drape-everything");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("unknown fabric test"), std::string::npos) << r.err;
  r = loom("fabric-test cantilever --overhang-ratio abc");
  EXPECT_EQ(r.code, 1);
  r = loom("fabric-test cantilever --bogus");
  EXPECT_EQ(r.code, 2);
  r = loom("fabric-test --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("--overhang-ratio"), std::string::npos);
}

}  // namespace
