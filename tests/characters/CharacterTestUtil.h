#pragma once
// Shared set-up of the character tests: the mocap clips shipped in tests/data/mocap, a file written into the
// test's folder, and the message of a loader's refusal.
#include <fstream>
#include <functional>
#include <string>

#include "TestDir.h"
#include "loom/cloth/Error.h"

namespace loom::test {

inline std::string mocap(const std::string& name) { return std::string(LOOM_TEST_DATA) + "/mocap/" + name; }

// Writes `text` (bytes) to `name` in the test's folder; returns its path.
inline std::string write_test_file(const std::string& name, const std::string& text) {
  const std::string path = (test_dir() / name).string();
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// The message of the loom::Error `f` throws; "" when it throws none.
inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const loom::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace loom::test
