#pragma once
// PC2 point caches: the vertex-animation format Blender's "Mesh Cache" modifier and Maya/3ds Max read.
// Layout (little-endian): char[12] "POINTCACHE2\0", int32 version (1), int32 points, float start_frame,
// float sample_rate (frames between samples), int32 samples, then samples x points x 3 float32 (x, y, z).
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "loom/cloth/OutputFile.h"
#include "loom/cloth/Types.h"

namespace loom::exporter {

// Streams samples to disk as they come; finish() writes the final sample count into the header.
class Pc2Writer {
 public:
  // `start_frame` and `sample_rate` are in frames (PC2 has no unit of time).
  Pc2Writer(std::string path, int points, double start_frame, double sample_rate);
  ~Pc2Writer();  // finishes if finish() was not called (errors are then swallowed)
  Pc2Writer(const Pc2Writer&) = delete;
  Pc2Writer& operator=(const Pc2Writer&) = delete;

  void add_sample(const cloth::Vec3s& x);  // m, exactly `points` positions
  void finish();
  int samples() const { return samples_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  OutputFile out_;
  int points_;
  int samples_ = 0;
  bool finished_ = false;
};

// A whole cache in memory (for tests and tools).
struct Pc2Cache {
  int points = 0;
  float start_frame = 0.0f;
  float sample_rate = 1.0f;
  int samples = 0;
  std::vector<float> xyz;  // samples x points x 3
};

// Reads a PC2 file; throws loom::Error naming the file and the problem on malformed input.
Pc2Cache read_pc2(const std::string& path);

}  // namespace loom::exporter
