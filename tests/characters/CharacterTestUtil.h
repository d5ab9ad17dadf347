#pragma once
// Shared set-up of the character tests: the mocap clips shipped in tests/data/mocap, and the message of a
// loader's refusal.
#include <functional>
#include <string>

#include "loom/cloth/Error.h"

namespace loom::test {

inline std::string mocap(const std::string& name) { return std::string(LOOM_TEST_DATA) + "/mocap/" + name; }

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
