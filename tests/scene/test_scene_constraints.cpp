// The `constraints` scene keys (strain_limit, tethers) and the new solvers' parameters: bad values are
// errors naming the file, the JSON path and the problem; the stages exist only when the scene names them.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "TestDir.h"
#include "loom/cloth/Error.h"
#include "loom/scene/Scene.h"

namespace loom::scene {
namespace {

namespace fs = std::filesystem;

const char* kScene = R"({
  "duration": 0.05, "fps": 60,
  "solver": {"method": "xpbd", "substeps": 2, "iterations": 4},
  "constraints": {"strain_limit": {"max_stretch": 0.1, "iterations": 4}, "tethers": {"slack": 0.0}},
  "cloths": [{"mesh": {"type": "grid", "size": [1, 1], "nodes": [5, 5]},
              "mass": 0.2,
              "pins": [{"grid": [0, 0]}, {"grid": [-1, 0]}]}]
})";

std::string write_scene(const std::string& name) {
  const fs::path p = test::test_dir() / (name + ".json");
  std::ofstream(p) << kScene;
  return p.string();
}

struct Case {
  const char* name;
  std::vector<std::string> sets;
  const char* where;
  const char* problem;
};

class ConstraintSceneErrors : public ::testing::TestWithParam<Case> {};

TEST_P(ConstraintSceneErrors, MessageNamesFilePathAndProblem) {
  const Case& c = GetParam();
  const std::string path = write_scene(c.name);
  std::string msg = "(no error)";
  try {
    Scene s = load_scene(path, c.sets);
    cloth::Simulation sim(s.setup, path);
  } catch (const Error& e) {
    msg = e.what();
  }
  EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
  EXPECT_NE(msg.find(c.where), std::string::npos) << "expected '" << c.where << "' in: " << msg;
  EXPECT_NE(msg.find(c.problem), std::string::npos) << "expected '" << c.problem << "' in: " << msg;
}

const Case kCases[] = {
    {"constraints_type", {"constraints=3"}, "constraints", "expected an object"},
    {"constraints_unknown", {"constraints.springs={}"}, "constraints.springs", "unknown key"},
    {"max_stretch_negative",
     {"constraints.strain_limit.max_stretch=-0.1"},
     "constraints.strain_limit.max_stretch",
     "must be >= 0"},
    {"max_stretch_string",
     {"constraints.strain_limit.max_stretch=\"ten\""},
     "constraints.strain_limit.max_stretch",
     "expected a number"},
    {"sl_iterations_zero",
     {"constraints.strain_limit.iterations=0"},
     "constraints.strain_limit.iterations",
     "must be >= 1"},
    {"sl_iterations_fraction",
     {"constraints.strain_limit.iterations=2.5"},
     "constraints.strain_limit.iterations",
     "expected an integer"},
    {"sl_unknown_key", {"constraints.strain_limit.tau=0.1"}, "constraints.strain_limit.tau", "unknown key"},
    {"slack_negative", {"constraints.tethers.slack=-1"}, "constraints.tethers.slack", "must be >= 0"},
    // The engine's bounds, refused by the scene with its file (scenes with rigid bodies built their
    // simulation without a file name, so the engine's message named none).
    {"max_stretch_huge",
     {"constraints.strain_limit.max_stretch=1e308"},
     "constraints.strain_limit.max_stretch",
     "must be below 1e6 (a stretch ratio; got 1e+308)"},
    {"slack_huge", {"constraints.tethers.slack=1e300"}, "constraints.tethers.slack", "must be below 1e6"},
    {"tether_distance",
     {"constraints.tethers.distance=manhattan"},
     "constraints.tethers.distance",
     "unknown value 'manhattan'"},
    {"xpbd_iterations", {"solver.iterations=0"}, "solver.iterations", "must be in [1"},
    {"pbd_stiffness", {"solver.method=pbd", "solver.stiffness=2"}, "solver.stiffness", "must be in [0"},
    {"projective_rho", {"solver.method=projective", "solver.rho=1.5"}, "solver.rho", "must be in [0"},
    {"projective_chebyshev",
     {"solver.method=projective", "solver.chebyshev=3"},
     "solver.chebyshev",
     "must be in [0"},
    {"desbrun_param",
     {"solver.method=desbrun"},
     "solver.iterations",
     "unknown parameter for method 'desbrun'"},
    {"projective_choi_ko",
     {"solver.method=projective", "cloths[0].model=choi_ko"},
     "cloths[0].model",
     "'choi_ko' cannot run with solver.method 'projective' (the scene's), which takes the springs model "
     "only"},
    {"realtime_tier_baraff_witkin",
     {"quality=realtime", "solver={}", "cloths[0].model=baraff_witkin"},
     "cloths[0].model",
     "'baraff_witkin' cannot run with solver.method 'fast_xpbd' (picked by \"quality\": \"realtime\")"},
};

INSTANTIATE_TEST_SUITE_P(All, ConstraintSceneErrors, ::testing::ValuesIn(kCases),
                         [](const auto& info) { return std::string(info.param.name); });

bool has(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

TEST(ConstraintScene, StagesExistOnlyWhenTheSceneNamesThem) {
  const std::string path = write_scene("stages");
  {
    Scene s = load_scene(path);
    ASSERT_TRUE(s.setup.strain_limit);
    EXPECT_EQ(s.setup.strain_limit->iterations, 4);
    EXPECT_DOUBLE_EQ(s.setup.strain_limit->max_stretch, 0.1);
    cloth::Simulation sim(s.setup, path);
    EXPECT_TRUE(has(sim.stage_names(), "strain_limit"));
    EXPECT_TRUE(has(sim.stage_names(), "tethers"));
    EXPECT_TRUE(sim.step_frame().finite);
  }
  {
    Scene s = load_scene(path, {"constraints={\"tethers\": {}}"});
    cloth::Simulation sim(s.setup, path);
    EXPECT_FALSE(has(sim.stage_names(), "strain_limit"));
    EXPECT_TRUE(has(sim.stage_names(), "tethers"));
  }
  {
    Scene s = load_scene(path, {"constraints={}"});
    cloth::Simulation sim(s.setup, path);
    EXPECT_FALSE(has(sim.stage_names(), "strain_limit"));
    EXPECT_FALSE(has(sim.stage_names(), "tethers"));
  }
}

}  // namespace
}  // namespace loom::scene
