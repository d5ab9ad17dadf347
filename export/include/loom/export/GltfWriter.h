#pragma once
// glTF 2.0 export of a cloth animation as ONE file pair, PATH.gltf + PATH.bin (the .bin next to it, named
// after it), readable by Blender, three.js, Godot, Unity/Unreal importers, tinygltf and assimp.
//
// Encoding: one node + mesh per cloth. The first frame given is the base mesh (POSITION, uint32 indices,
// a double-sided material). Every later frame k becomes morph target k-1 holding the displacement
// x_k - x_0 (float32). One animation ("simulation") has a "weights" channel per node with a LINEAR sampler
// whose key k (at the frame's time in seconds) has weight 1 on target k-1 and 0 elsewhere, so playing it
// interpolates linearly between consecutive simulated frames. Target names are in mesh.extras.targetNames
// ("frame_00001", ...) as Blender expects. The weights output (keys x targets floats, one-hot) is a sparse
// accessor (glTF 2.0 section 3.6.2.3: no bufferView, so all zeros, then `sparse.count` = targets uint32
// indices k*targets + k-1 replaced by 1.0), so the .bin holds frames x vertices x 12 bytes plus 12 bytes a
// frame (times, sparse indices and values): it grows linearly with the frames (a 33x33 cloth for 180 frames
// is about 2.4 MB). A reader that expands the weights holds frames² x 4 bytes of them in memory.
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "loom/cloth/OutputFile.h"
#include "loom/cloth/Types.h"

namespace loom::exporter {

struct AnimatedMesh {
  std::string name;
  int vertices = 0;
  std::vector<cloth::Tri> triangles;
};

class GltfWriter {
 public:
  GltfWriter(std::string gltf_path, std::vector<AnimatedMesh> meshes);
  GltfWriter(const GltfWriter&) = delete;
  GltfWriter& operator=(const GltfWriter&) = delete;

  // One pointer per mesh, in the constructor's order. `time` in s; times must increase.
  void add_frame(double time, const std::vector<const cloth::Vec3s*>& positions);
  // Appends the animation data to the .bin and writes the .gltf; call once after the last frame.
  void finish();

  int frames() const { return static_cast<int>(times_.size()); }
  const std::string& gltf_path() const { return gltf_path_; }
  const std::string& bin_path() const { return bin_path_; }

 private:
  struct View {  // one bufferView
    size_t offset = 0, bytes = 0;
    int target = 0;  // 34962 ARRAY_BUFFER, 34963 ELEMENT_ARRAY_BUFFER, 0 none
  };
  struct Accessor {
    int view = -1;      // bufferView index; -1: none (a sparse accessor over zeros)
    int component = 0;  // 5126 FLOAT, 5125 UNSIGNED_INT
    std::string type;   // "VEC3", "SCALAR"
    size_t count = 0;
    std::vector<double> min, max;
    size_t sparse_count = 0;  // > 0: a sparse accessor with uint32 indices and values in these views
    int sparse_indices = -1, sparse_values = -1;
  };
  int append_view(const void* data, size_t bytes, int target);  // returns the bufferView index
  // Appends a bufferView holding `data` and one accessor on it; returns the accessor index.
  int append(const void* data, size_t bytes, int target, Accessor accessor);
  int append_vec3(const cloth::Vec3s& v, const cloth::Vec3s* minus);

  std::string gltf_path_, bin_path_;
  std::vector<AnimatedMesh> meshes_;
  OutputFile bin_;
  size_t bin_size_ = 0;
  std::vector<View> views_;
  std::vector<Accessor> accessors_;
  std::vector<double> times_;       // s
  std::vector<cloth::Vec3s> base_;  // frame 0 per mesh
  std::vector<int> base_accessor_, index_accessor_;
  std::vector<std::vector<int>> target_accessor_;  // [mesh][target]
  bool finished_ = false;
};

}  // namespace loom::exporter
