// libFuzzer target: what `loom run --resume` reads from a checkpoint folder (apps/loom/Checkpoint.h).
// The first byte picks the reader, the rest is its input:
//   0: a checkpoint file (decode_checkpoint): it either decodes, with counts in range, to a checkpoint that
//      encodes and decodes back to the same header, or throws loom::Error;
//   1: a frame log (parse_frame_log) for two cloths of 4 and 9 vertices, asked for a `keep` taken from the
//      input's first 8 bytes (any 64-bit count, the wrapping ones included): it either returns `keep` entries
//      of finite positions or throws loom::Error;
//   2: a simulation state archive (Simulation::load_state) for a small two-cloth scene: it either loads or
//      throws loom::Error.
// Anything else (a crash, a sanitizer report, another exception) is a bug.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "Checkpoint.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/StateArchive.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace {

loom::cloth::Simulation& simulation() {
  static std::unique_ptr<loom::cloth::Simulation> sim = [] {
    const auto j = nlohmann::json::parse(R"({
      "solver": {"method": "bdf2"},
      "cloths": [{"mesh": {"type": "grid", "size": [1, 1], "nodes": [2, 2]}},
                 {"mesh": {"type": "grid", "size": [1, 1], "nodes": [3, 3]}, "pins": [{"grid": [0, 0]}]}],
      "colliders": [{"shape": "sphere", "radius": 0.1}]
    })");
    return loom::scene::build_simulation(loom::scene::parse_scene(j, "/nonexistent/fuzz.json"));
  }();
  return *sim;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1 || size > 256 * 1024) return 0;
  const int mode = data[0] % 3;
  const std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    if (mode == 0) {
      const loom::app::Checkpoint c = loom::app::decode_checkpoint(bytes, "fuzz.bin");
      if (c.frame < 0 || c.frame > c.frames_total || c.logged_frames < 0 || c.threads < 1) __builtin_trap();
      const loom::app::Checkpoint d =
          loom::app::decode_checkpoint(loom::app::encode_checkpoint(c), "again.bin");
      if (d.frame != c.frame || d.logged_frames != c.logged_frames || d.state != c.state ||
          d.scene != c.scene || d.inputs.size() != c.inputs.size() || d.run_id != c.run_id)
        __builtin_trap();
    } else if (mode == 1) {
      long keep = 0;
      if (bytes.size() >= sizeof keep) std::memcpy(&keep, bytes.data(), sizeof keep);
      const std::string log = bytes.size() >= sizeof keep ? bytes.substr(sizeof keep) : std::string();
      const auto entries = loom::app::parse_frame_log(log, keep, {4, 9}, "frames.bin");
      if (static_cast<long>(entries.size()) != keep) __builtin_trap();
      for (const auto& e : entries)
        if (e.x.size() != 2 || e.x[0].size() != 4 || e.x[1].size() != 9) __builtin_trap();
    } else {
      loom::cloth::StateReader in(bytes, "fuzz.bin");
      simulation().load_state(in);
    }
  } catch (const loom::Error&) {
  }
  return 0;
}
