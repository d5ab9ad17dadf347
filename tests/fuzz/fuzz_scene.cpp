// libFuzzer target: the scene parser (JSON text -> loom::scene::parse_scene). Any input must either
// parse or throw loom::Error; any other exception, crash or sanitizer report is a bug.
// The harness keeps the run bounded: mesh "path" and character "bvh" values are replaced by a missing file
// (the OBJ loader has its own target) and grids above 64x64 nodes are skipped (a valid large grid is slow,
// not wrong).
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "loom/cloth/Error.h"
#include "loom/scene/Scene.h"

namespace {

// False if the input asks for more work than a fuzz iteration should do.
bool tame(nlohmann::json& j) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      // Files named by the scene (meshes, motion clips) could be anything on this machine: never opened.
      if ((it.key() == "path" || it.key() == "bvh") && it.value().is_string())
        it.value() = "/nonexistent/loom_fuzz.obj";
      if (it.key() == "nodes" && it.value().is_array())
        for (const auto& n : it.value())
          if (n.is_number() && n.get<double>() > 64) return false;
      if (!tame(it.value())) return false;
    }
  } else if (j.is_array()) {
    for (auto& e : j)
      if (!tame(e)) return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  nlohmann::json root = nlohmann::json::parse(text, nullptr, false);
  if (root.is_discarded() || !tame(root)) return 0;
  try {
    loom::scene::Scene s = loom::scene::parse_scene(root, "/nonexistent/fuzz.json");
    (void)s;
  } catch (const loom::Error&) {
  }
  return 0;
}
