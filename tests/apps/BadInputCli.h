#pragma once
// The bad-input table of `loom run` (test_bad_input_cli.cpp runs every row; its rows are split over
// test_bad_input_cli.cpp and test_bad_input_cli_limits.cpp).
#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace loom::test {

struct BadInput {
  const char* name;
  const char* scene;              // scene text; nullptr: kValid
  std::vector<const char*> args;  // extra `loom run` arguments (--set ...); "@OBJ" = path of the case's OBJ
  const char* obj;                // text of DIR/mesh.obj (of DIR/motion.bvh with @BVHTEXT) or nullptr
  const char* file;               // whose name the message must hold: "scene", "obj", "out", or a literal
  const char* where;              // field, JSON path or line named in the message
  const char* problem;            // words of the problem
};

class BadInputCli : public ::testing::TestWithParam<BadInput> {};

inline std::string bad_input_name(const ::testing::TestParamInfo<BadInput>& info) { return info.param.name; }

// Rows in test_bad_input_cli_limits.cpp.
size_t bad_input_limit_rows();

}  // namespace loom::test
