#pragma once
// A scratch folder per running test. ctest runs every test as its own process, two at a time, so tests of one
// executable must never share a file: a test that rewrites a shared scene file while another reads it sees a
// half-written file now and then (CI failed on exactly that in OutputRender.DefaultsAndCamera).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

namespace loom::test {

// <tmp>/loom_tests/<suite>.<test>.<pid>: emptied at the test's first call (a reused pid must not leave an old
// run's files for a check that a file is *not* written), then created; later calls in the test keep it.
inline std::filesystem::path test_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name =
      std::string(info->test_suite_name()) + "." + info->name() + "." + std::to_string(getpid());
  for (char& c : name)
    if (c == '/') c = '_';
  const auto dir = std::filesystem::temp_directory_path() / "loom_tests" / name;
  static std::string emptied;  // the test whose folder was emptied last, in this process
  if (emptied != name) std::filesystem::remove_all(dir), emptied = name;
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace loom::test
