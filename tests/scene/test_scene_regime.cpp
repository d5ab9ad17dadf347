// The divergence report (SceneRegime.h): each value outside the validated regime is named by its field, a
// scene inside it names the fields that give a frame more steps, and no bundled scene is outside it.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "loom/scene/Scene.h"
#include "loom/scene/SceneRegime.h"

namespace loom::test {
namespace {

const char* kSheet = R"({
  "name": "sheet", "duration": 0.1, "fps": 60,
  "solver": {"method": "symplectic_euler", "substeps": 40},
  "cloths": [{"name": "sheet",
              "mesh": {"type": "grid", "size": [1, 1], "nodes": [9, 9], "origin": [0, 1.5, 0]},
              "material": {"preset": "cotton"}, "mass": 0.2,
              "pins": [{"grid": [0, 0]}, {"grid": [-1, 0]}]}]
})";

std::string suspects(const std::vector<std::string>& overrides) {
  const nlohmann::json root = nlohmann::json::parse(kSheet);
  nlohmann::json j = root;
  for (const std::string& o : overrides) scene::apply_override(j, o, "sheet.json");
  return scene::divergence_suspects(scene::parse_scene(j, "sheet.json"));
}

struct RegimeCase {
  std::vector<std::string> overrides;
  const char* field;   // the field the report must name
  const char* figure;  // and its figure
};

// The report of the scene with c's overrides names c's field with its figure.
void expect_named(const RegimeCase& c) {
  const std::string text = suspects(c.overrides);
  SCOPED_TRACE(c.overrides[0]);
  EXPECT_NE(text.find("outside the validated regime: "), std::string::npos) << text;
  EXPECT_NE(text.find(c.field), std::string::npos) << text;
  EXPECT_NE(text.find(c.figure), std::string::npos) << text;
}

TEST(SceneRegime, EachValueOutsideTheRegimeIsNamedByItsFieldWithItsFigure) {
  const RegimeCase cases[] = {
      {{"gravity=[1e4,1e4,1e4]"}, "gravity (|g| = 1.73e+04 m/s^2", "1.77e+03 g"},
      {{"gravity=[0,-200,0]"}, "gravity (|g| = 200 m/s^2", "validated up to 98.1"},
      {{"cloths[0].material.stretch=1e12", "solver.method=implicit_euler"},
       "cloths[0].material stretch with its areal density",
       "stretch waves at 2.24e+06 m/s"},
      {{"cloths[0].material.stretch=1e7"}, "solver.substeps for cloths[0]", "explicit symplectic_euler"},
      {{"cloths[0].velocity=[0,300,0]"}, "cloths[0].velocity (300 m/s", "validated up to 100"},
      {{"effects={\"drag\":{\"isotropic\":10,\"wind\":[1000,0,0]}}"},
       "effects.drag.wind",
       "pushes at 5e+04 m/s^2"},
      {{"effects={\"drag\":{\"normal\":1e6}}"}, "effects.drag.normal", "relaxes the velocity"},
      {{"effects={\"wind\":{\"velocity\":[300,0,0]}}"}, "effects.wind", "pushes at 2.7e+05 m/s^2"},
      {{"cloths[0].material={\"preset\":\"cotton\",\"damping\":2}"},
       "cloths[0].material.damping (2 s",
       "per step"},
      {{"cloths[0].pins[0]={\"grid\":[0,0],\"anchor\":[0,1.5,-3]}"},
       "cloths[0].pins[0] (its first target lies 3 m from its vertex",
       "a quarter of the cloth's size"},
  };
  for (const RegimeCase& c : cases) expect_named(c);
}

TEST(SceneRegime, AValueJustInsideTheRegimeIsNotNamed) {
  for (const std::string& o : {std::string("gravity=[0,-98,0]"), std::string("cloths[0].velocity=[0,99,0]"),
                               std::string("effects={\"wind\":{\"velocity\":[10,0,0]}}")}) {
    const std::string text = suspects({o});
    EXPECT_NE(text.find("no scene value is outside the validated regime"), std::string::npos)
        << o << ": " << text;
  }
}

// The pressure note quotes the net pressure acting on the cloth (inside minus outside), not the sum of the
// magnitudes: an ideal gas at 1 Pa absolute inside 1e5 Pa of ambient air is pulled in by -99999 Pa, never
// pushed by 2e5 Pa; the ambient pressure alone pushes on both sides and is not named.
TEST(SceneRegime, ThePressureNoteQuotesTheNetPressureActingOnTheCloth) {
  const std::string pillow = std::string(LOOM_SOURCE_DIR) + "/scenes/pillow.json";
  auto text = [&](const std::string& pressure) {
    return scene::divergence_suspects(scene::load_scene(pillow, {"cloths[0].pressure=" + pressure}));
  };
  const std::string low = text(R"({"model":"ideal_gas","ambient":1e5,"overpressure":-99999})");
  EXPECT_NE(
      low.find("cloths[0].pressure (a net -1e+05 Pa, inside minus outside at the rest volume, pulls the "
               "cloth in at "),
      std::string::npos)
      << low;
  EXPECT_EQ(low.find("2e+05 Pa"), std::string::npos) << low;
  const std::string ambient = text(R"({"model":"ideal_gas","ambient":1e8,"overpressure":300})");
  EXPECT_EQ(ambient.find("cloths[0].pressure"), std::string::npos) << ambient;
}

// The reference tier is suggested only to a scene that runs another one.
TEST(SceneRegime, ASceneInsideTheRegimeNamesTheFieldsThatGiveAFrameMoreSteps) {
  const std::string text = suspects({});
  EXPECT_NE(text.find("solver.substeps (now 40 per frame)"), std::string::npos) << text;
  EXPECT_NE(text.find("guard.max_halvings"), std::string::npos) << text;
  EXPECT_EQ(text.find("\"quality\""), std::string::npos) << text;
  const std::string realtime = suspects({"quality=realtime"});
  EXPECT_NE(realtime.find("\"quality\": \"reference\""), std::string::npos) << realtime;
}

// Colliders: a kinematic motion whose surface outruns the regime (a fast origin, or a fast turn of a large
// box), and a cloth that starts inside a collider or its thickness, are named by field with the figure.
TEST(SceneRegime, FastCollidersAndClothsStartingInsideOneAreNamed) {
  const RegimeCase cases[] = {
      {{"colliders=[{\"name\":\"c\",\"shape\":\"sphere\",\"radius\":0.1,\"position\":[0,-100,0],"
        "\"motion\":{\"velocity\":[0,5000,0]}}]"},
       "colliders[0].motion (its surface moves at up to 5e+03 m/s",
       "validated up to 100"},
      {{"colliders=[{\"name\":\"c\",\"shape\":\"box\",\"half_extents\":[0.3,0.05,0.3],\"position\":[3,0,0],"
        "\"motion\":{\"spin\":{\"axis\":[0,1,0],\"rate\":1000}}}]"},
       "colliders[0].motion (its surface moves at up to 427 m/s",
       "validated up to 100"},
      {{"colliders=[{\"name\":\"big\",\"shape\":\"capsule\",\"radius\":1000,\"half_height\":1,"
        "\"position\":[0,1.5,0]}]"},
       "cloths[0] starts inside colliders[0] 'big' or its thickness",
       "m in)"},
      {{"colliders=[{\"name\":\"floor\",\"shape\":\"plane\",\"position\":[0,1.499,0],\"thickness\":0.004}]"},
       "cloths[0] starts inside colliders[0] 'floor' or its thickness (vertex 0, 0.003 m in)",
       "starts inside"},
  };
  for (const RegimeCase& c : cases) expect_named(c);
  // A slow spin and a collider the cloth starts clear of are not named.
  const std::string slow =
      suspects({"colliders=[{\"name\":\"c\",\"shape\":\"box\",\"half_extents\":[0.3,0.05,"
                "0.3],\"position\":[0,0.5,0],\"motion\":{\"spin\":{\"axis\":[0,1,0],"
                "\"rate\":10}}}]"});
  EXPECT_NE(slow.find("no scene value is outside the validated regime"), std::string::npos) << slow;
}

// Bullet bodies as colliders: a cloth that starts inside a body at its pose at t = 0 (a static plane whose
// solid half-space (below y = 5) holds the sheet, a box across it, a kinematic sphere) is named by the body's
// field and name; a body's own attached vertices, where it holds the cloth, are not a start inside it.
TEST(SceneRegime, ClothsStartingInsideABodyAreNamedByTheBody) {
  const RegimeCase cases[] = {
      {{"bodies=[{\"name\":\"wall\",\"shape\":\"plane\",\"position\":[0,5,0]}]"},
       "cloths[0] starts inside bodies[0] 'wall' (vertex",
       "m in)"},
      {{"bodies=[{\"name\":\"block\",\"shape\":\"box\",\"half_extents\":[0.2,0.2,0.2],"
        "\"position\":[0.5,1.5,0.5]}]"},
       "cloths[0] starts inside bodies[0] 'block' (vertex",
       "m in)"},
      {{"bodies=[{\"name\":\"ball\",\"shape\":\"sphere\",\"radius\":0.05,\"position\":[0,1.5,0],"
        "\"motion\":{\"oscillate\":{\"amplitude\":[0,0.1,0],\"frequency\":1}}}]"},
       "cloths[0] starts inside bodies[0] 'ball' (vertex 0, 0.05 m in)",
       "starts inside"},
  };
  for (const RegimeCase& c : cases) expect_named(c);
  // A sphere holding the middle vertex (and no other point of the cloth inside it) is not named.
  const std::string held =
      suspects({"bodies=[{\"name\":\"ball\",\"shape\":\"sphere\",\"radius\":0.05,"
                "\"position\":[0.5,1.5,0.5],\"mass\":1,\"attach\":[{\"grid\":[4,4]}]}]"});
  EXPECT_NE(held.find("no scene value is outside the validated regime"), std::string::npos) << held;
  const std::string free_ball =
      suspects({"bodies=[{\"name\":\"ball\",\"shape\":\"sphere\",\"radius\":0.05,"
                "\"position\":[0.5,1.5,0.5],\"mass\":1}]"});
  EXPECT_NE(free_ball.find("cloths[0] starts inside bodies[0] 'ball' (vertex 40, 0.05 m in)"),
            std::string::npos)
      << free_ball;
}

// A pin's path moves its vertex like a kinematic collider moves its surface: a key interval faster than the
// regime's speed is named by the path with its figure; a slow path is not.
TEST(SceneRegime, AFastPinPathIsNamedByThePath) {
  expect_named({{"cloths[0].pins[1].path={\"times\":[0,0.01],\"offsets\":[[0,0,0],[5,0,0]]}"},
                "cloths[0].pins[1].path (moves its vertex at up to 500 m/s",
                "validated up to 100"});
  const std::string slow =
      suspects({"cloths[0].pins[1].path={\"times\":[0,1],\"offsets\":[[0,0,0],[5,0,0]]}"});
  EXPECT_NE(slow.find("no scene value is outside the validated regime"), std::string::npos) << slow;
}

// A scene outside the regime gets one retry of a failed frame unless it sets guard.max_halvings; inside it,
// or outside it only by values per solver step, the default five.
TEST(SceneRegime, ASceneOutsideTheRegimeRetriesAFrameOnceUnlessItSaysOtherwise) {
  auto halvings = [](const std::vector<std::string>& overrides) {
    nlohmann::json j = nlohmann::json::parse(kSheet);
    for (const std::string& o : overrides) scene::apply_override(j, o, "sheet.json");
    return scene::parse_scene(j, "sheet.json").setup.guard.max_halvings;
  };
  EXPECT_EQ(halvings({}), 5);
  EXPECT_EQ(halvings({"gravity=[0,-200,0]"}), scene::kRegimeOutsideHalvings);
  EXPECT_EQ(halvings({"gravity=[0,-200,0]", "guard.max_halvings=4"}), 4);
  EXPECT_EQ(halvings({"guard.max_halvings=0"}), 0);
  // An explicit step's Courant number past 1 is what more substeps cure: the retries stay.
  EXPECT_EQ(halvings({"cloths[0].material.stretch=1e7"}), 5);
}

// The regime is what the bundled scenes stay inside: none of them is reported.
TEST(SceneRegime, NoBundledSceneIsOutsideTheRegime) {
  int loaded = 0;
  for (const auto& e : std::filesystem::directory_iterator(std::string(LOOM_SOURCE_DIR) + "/scenes")) {
    if (e.path().extension() != ".json") continue;
    scene::Scene sc;
    try {
      sc = scene::load_scene(e.path().string());
    } catch (const std::exception& ex) {  // a scene needing a part this build lacks (Bullet, characters)
      const std::string what = ex.what();
      if (what.find("built without") != std::string::npos) continue;
      ADD_FAILURE() << e.path() << ": " << what;
      continue;
    }
    ++loaded;
    EXPECT_NE(scene::divergence_suspects(sc).find("no scene value is outside"), std::string::npos)
        << e.path() << ": " << scene::divergence_suspects(sc);
  }
  EXPECT_GE(loaded, 20);
}

}  // namespace
}  // namespace loom::test
