#pragma once
// Shared set-up of the character tests: the mocap clips shipped in tests/data/mocap.
#include <string>

namespace loom::test {

inline std::string mocap(const std::string& name) { return std::string(LOOM_TEST_DATA) + "/mocap/" + name; }

}  // namespace loom::test
