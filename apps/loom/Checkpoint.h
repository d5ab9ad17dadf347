#pragma once
// Checkpoints of `loom run`: `--checkpoint-every N` writes DIR/checkpoint/checkpoint.bin every N
// frames (and on Ctrl-C), atomically (temp file + rename); `--resume DIR` continues from it bit-identically
// to an uninterrupted run. The file holds a JSON header (the run: scene text, --set overrides, frames, the
// totals of the outputs so far) and the simulation's state archive (cloth::Simulation::save_state).
// Geometry written per frame by exporters that keep the whole run in memory (pc2, gltf, --render) is
// replayed on resume from DIR/checkpoint/frames.bin, an append-only log of the written frames' positions.
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "loom/cloth/Simulation.h"

namespace loom::app {

struct Checkpoint {
  std::string scene;                // scene path of the run
  std::string scene_text;           // the scene file's text then: resuming a changed scene is an error
  std::vector<std::string> sets;    // --set overrides
  int frames_total = 0;             // frames the run was asked for
  int threads = 1;
  int checkpoint_every = 0;
  bool render = false;
  int frame = 0;                    // frames done when written
  double max_strain = 0.0;          // 1, run totals so far (summary.json)
  double mean_strain_sum = 0.0;     // 1, sum of per-frame mean strains
  double sim_ms = 0.0;              // ms of pipeline time so far
  long logged_frames = 0;           // entries of frames.bin that belong to frames <= frame
  std::string state;                // cloth::Simulation state archive
};

// Writes DIR/checkpoint/checkpoint.bin through a temporary file and a rename.
void write_checkpoint(const std::filesystem::path& out, const Checkpoint& c);
// Reads DIR/checkpoint/checkpoint.bin; errors name the file and the problem.
Checkpoint read_checkpoint(const std::filesystem::path& out);
std::string read_text_file(const std::string& path);
// The data rows of DIR/stats.csv (or of DIR/stats.csv.partial after a crash) for frames <= `frame`.
std::string kept_stats_rows(const std::filesystem::path& out, int frame);

// DIR/checkpoint/frames.bin: per written frame, the time and every cloth's positions.
class FrameLog {
 public:
  // Opens the log for appending after keeping its first `keep` entries (0: a new log).
  FrameLog(const std::filesystem::path& out, long keep, const std::vector<std::unique_ptr<cloth::Cloth>>& cloths);
  // `flags`: what the frame was written for (bit 0: exporters, bit 1: the render recording).
  void append(double time, int flags, const std::vector<std::unique_ptr<cloth::Cloth>>& cloths);
  void flush() { file_.flush(); }
  long entries() const { return entries_; }
  // Calls fn(time, flags) for each kept entry with the cloths' positions set to the logged ones, then puts
  // the positions back.
  template <class Fn>
  void replay(std::vector<std::unique_ptr<cloth::Cloth>>& cloths, Fn fn) const;

 private:
  std::filesystem::path path_;
  std::ofstream file_;
  long entries_ = 0;
  size_t entry_bytes_ = 0;
  struct Entry {
    double time;  // s
    int flags;
    std::vector<cloth::Vec3s> x;  // m, per cloth
  };
  std::vector<Entry> kept_;
};

template <class Fn>
void FrameLog::replay(std::vector<std::unique_ptr<cloth::Cloth>>& cloths, Fn fn) const {
  std::vector<cloth::Vec3s> now;
  for (const auto& c : cloths) now.push_back(c->state().x);
  for (const Entry& e : kept_) {
    for (size_t k = 0; k < cloths.size(); ++k) cloths[k]->state().x = e.x[k];
    fn(e.time, e.flags);
  }
  for (size_t k = 0; k < cloths.size(); ++k) cloths[k]->state().x = now[k];
}

}  // namespace loom::app
