#pragma once
// Runs the `loom` binary for end-to-end tests. Output goes through files in a folder of the calling test's
// own (suite, name, pid): ctest runs every test as its own process, in parallel.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "TestDir.h"

namespace loom::test {

// True in the AddressSanitizer build (GCC's and clang's spellings): its binaries run many times slower and
// stop before main under a `ulimit -v`.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif
#else
constexpr bool kAddressSanitizer = false;
#endif

struct CliResult {
  int code = -1;  // exit code, -1 if the process did not exit normally
  std::string out, err;
};

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Writes a scene (a JSON value: anything with dump(indent)) into the test's scratch folder; returns its path.
template <class Json>
std::string write_json_scene(const std::string& name, const Json& j) {
  const auto path = test_dir() / name;
  std::ofstream(path) << j.dump(1);
  return path.string();
}

// DIR/summary.json of a run's output folder, parsed.
inline nlohmann::json summary_of(const std::string& out) {
  return nlohmann::json::parse(slurp(std::filesystem::path(out) / "summary.json"));
}

// `loom ARGS` in a shell, with `env` (NAME=VALUE words, may be empty) in its environment.
inline CliResult run_loom(const std::string& args, const std::string& env = "") {
  const auto dir = test_dir();
  const std::string out = (dir / "stdout.txt").string(), err = (dir / "stderr.txt").string();
  const int status =
      std::system((env + " " + std::string(LOOM_BINARY) + " " + args + " >" + out + " 2>" + err).c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

}  // namespace loom::test
