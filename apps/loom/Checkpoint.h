#pragma once
// Checkpoints of `loom run`: `--checkpoint-every N` writes DIR/checkpoint/checkpoint.bin every N frames (and
// on Ctrl-C), atomically (temp file + rename); `--resume DIR` continues from it bit-identically to an
// uninterrupted run. Format (version kCheckpointFormat):
//   "LOOMCKPT" <format, 1 decimal digit> "\n" | u64 header bytes | JSON header | u64 state bytes | state
//   | u64 FNV-1a 64 checksum of every byte before it
// The header holds the run (absolute scene path, scene text, --set overrides, frames, totals so far), the
// output folder's run id (OutputFolder.h), every input file with its size and FNV-1a 64 hash (scene, meshes,
// motion clips), the hash of the frame log's kept entries and the hash of the OBJ frames written so far.
// Resume refuses, naming the file: another format, a checksum mismatch, another folder's checkpoint, a
// changed or missing input, a changed frame log, a frame file removed or changed.
// Geometry written per frame by exporters that keep the whole run in memory (pc2, gltf, --render) is
// replayed on resume from DIR/checkpoint/frames.bin, an append-only log of the written frames' positions.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "loom/cloth/OutputFile.h"
#include "loom/cloth/Simulation.h"

namespace loom::eval {
class OutputFolder;
std::uint64_t read_run_id(const std::filesystem::path& dir);
}  // namespace loom::eval

namespace loom::app {

using eval::OutputFolder;
using eval::read_run_id;

constexpr int kCheckpointFormat = 3;

// FNV-1a, 64 bits (Fowler, Noll, Vo), continued from `h` (kFnvOffset: the start of a new hash).
constexpr std::uint64_t kFnvOffset = 0xcbf29ce484222325ull;
std::uint64_t fnv1a(const char* data, size_t n, std::uint64_t h = kFnvOffset);
inline std::uint64_t fnv1a(const std::string& s) { return fnv1a(s.data(), s.size()); }

struct InputFile {
  std::string path;  // absolute
  std::uint64_t bytes = 0;
  std::uint64_t hash = 0;  // FNV-1a 64 of the contents
};
// Size and hash of an input file now; errors name the file.
InputFile fingerprint(const std::string& path);

struct Checkpoint {
  std::string scene;              // absolute scene path of the run
  std::string scene_text;         // the scene file's text then: resuming a changed scene is an error
  std::vector<std::string> sets;  // --set overrides
  std::uint64_t run_id = 0;       // the output folder's (OutputFolder::run_id)
  std::vector<InputFile> inputs;  // every file the scene read
  int frames_total = 0;           // frames the run was asked for
  int threads = 1;
  int checkpoint_every = 0;
  bool render = false;
  int frame = 0;                 // frames done when written
  int frame_digits = 5;          // digits of the numbers in frames/frame_N.obj (kept by every resume)
  double max_strain = 0.0;       // 1, run totals so far (summary.json)
  double mean_strain_sum = 0.0;  // 1, sum of per-frame mean strains
  double sim_ms = 0.0;           // ms of pipeline time so far
  long logged_frames = 0;        // entries of frames.bin that belong to frames <= frame
  std::uint64_t log_hash = 0;    // FNV-1a 64 of those entries' bytes
  // FNV-1a 64 of the frame files frames/frame_N.obj written up to `frame`, their bytes in frame order: resume
  // refuses a folder whose frames were removed or changed since (the run would not be whole).
  std::uint64_t frames_hash = kFnvOffset;
  // FNV-1a 64 of each of those frame files alone, in frame order: on a frames_hash mismatch they name the
  // first file that changed (empty in checkpoints of earlier looms).
  std::vector<std::uint64_t> frame_hashes;
  std::string state;  // cloth::Simulation state archive
};

// The bytes of a checkpoint file, and back (errors name `source` and the problem; any input either decodes
// to a header whose counts are in range or throws loom::Error).
std::string encode_checkpoint(const Checkpoint& c);
Checkpoint decode_checkpoint(const std::string& data, const std::string& source);

// Writes DIR/checkpoint/checkpoint.bin through a temporary file and a rename.
void write_checkpoint(OutputFolder& out, const Checkpoint& c);
// Reads DIR/checkpoint/checkpoint.bin; errors name the file and the problem.
Checkpoint read_checkpoint(const std::filesystem::path& out);
// Refuses (loom::Error naming the file) an input that changed or went missing since `c` was written.
void check_inputs(const Checkpoint& c);
// Reads a regular file of at most `max_bytes` (errors name the file: missing, a folder, a device, too big).
std::string read_text_file(const std::string& path, std::uint64_t max_bytes = std::uint64_t(1) << 32);
// The data rows of DIR/stats.csv (or of DIR/stats.csv.partial after a crash) for frames <= `frame`.
std::string kept_stats_rows(const std::filesystem::path& out, int frame);

// One entry of the frame log: the time and every cloth's positions.
struct FrameLogEntry {
  double time;  // s
  int flags;
  std::vector<cloth::Vec3s> x;  // m, per cloth
};
// The first `keep` entries of a frame log's bytes for cloths of `vertices[k]` vertices; errors name `source`.
std::vector<FrameLogEntry> parse_frame_log(const std::string& data, long keep,
                                           const std::vector<size_t>& vertices, const std::string& source);

// DIR/checkpoint/frames.bin: per written frame, the time and every cloth's positions.
class FrameLog {
 public:
  // Opens the log for appending after keeping its first `keep` entries, whose bytes must hash to `hash`
  // (0 entries: a new log).
  FrameLog(OutputFolder& out, long keep, std::uint64_t hash,
           const std::vector<std::unique_ptr<cloth::Cloth>>& cloths);
  // `flags`: what the frame was written for (bit 0: exporters, bit 1: the render recording).
  void append(double time, int flags, const std::vector<std::unique_ptr<cloth::Cloth>>& cloths);
  void flush() { file_.flush(); }
  long entries() const { return entries_; }
  std::uint64_t hash() const { return hash_; }
  // Calls fn(time, flags) for each kept entry with the cloths' positions set to the logged ones, then puts
  // the positions back.
  template <class Fn>
  void replay(std::vector<std::unique_ptr<cloth::Cloth>>& cloths, Fn fn) const;

 private:
  void put(const void* p, size_t n);
  std::filesystem::path path_;
  OutputFile file_;
  long entries_ = 0;
  std::uint64_t hash_ = 0;
  std::vector<FrameLogEntry> kept_;
};

template <class Fn>
void FrameLog::replay(std::vector<std::unique_ptr<cloth::Cloth>>& cloths, Fn fn) const {
  std::vector<cloth::Vec3s> now;
  for (const auto& c : cloths) now.push_back(c->state().x);
  for (const FrameLogEntry& e : kept_) {
    for (size_t k = 0; k < cloths.size(); ++k) cloths[k]->state().x = e.x[k];
    fn(e.time, e.flags);
  }
  for (size_t k = 0; k < cloths.size(); ++k) cloths[k]->state().x = now[k];
}

}  // namespace loom::app
