#pragma once
// `loom run`: loads a scene, runs it and writes DIR/frames/*.obj, DIR/stats.csv and DIR/summary.json into an
// output folder it owns (OutputFolder.h, docs/guarantees.md).
#include <string>
#include <vector>

namespace loom::app {

struct RunOptions {
  std::string scene;  // empty: the default scene
  std::string out;    // empty: out/<scene name>
  int frames = -1;    // -1: the scene's duration
  int threads = -1;   // -1: the scene's value
  bool profile = false;
  bool render = false;            // --render: DIR/render/*.png, DIR/render.mp4, DIR/render.gif
  std::vector<std::string> sets;  // --set PATH=VALUE
  bool census = false;            // --census: intersections and max_penetration in summary.json
  int checkpoint_every = 0;  // --checkpoint-every N: DIR/checkpoint/checkpoint.bin every N frames (0: off)
  std::string resume;        // --resume DIR: continue the run whose checkpoint is in DIR
  bool overwrite = false;    // --overwrite: write into a non-empty folder without a Loom manifest
};

// Returns the process exit code: 0 ok, 1 bad input or I/O error, 3 the simulation diverged, 130 interrupted
// by Ctrl-C (outputs valid, a checkpoint written).
int run_command(const RunOptions& options);
std::string default_scene_path();

}  // namespace loom::app
