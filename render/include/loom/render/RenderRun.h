#pragma once
// `loom run --render`: keeps the positions of every rendered frame while the simulation runs, then (so
// the camera can be framed on the whole motion) renders DIR/render/frame_00000.png ... (numbered by
// rendered frame). The CLI encodes the video from them (loom/eval/HelperProgram.h, ffmpeg_video).
#include <csignal>
#include <memory>
#include <string>
#include <vector>

#include "loom/cloth/Cloth.h"
#include "loom/render/Renderer.h"

namespace loom::render {

// Meshes as drawn (warp/weft material coordinates from the cloth's triangle frames); colours cycle.
std::vector<RenderMesh> render_meshes(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths);

// Colliders: the simulation's collider set (scene::build_simulation); each added frame keeps their `curr`
// poses, so every image shows them where they were at that frame.
class Recording {
 public:
  explicit Recording(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths,
                     collision::ColliderSetPtr colliders = nullptr)
      : meshes_(render_meshes(cloths)), colliders_(std::move(colliders)) {}
  void add(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths);
  int frames() const { return static_cast<int>(frames_.size()); }
  const std::vector<RenderMesh>& meshes() const { return meshes_; }
  const std::vector<std::vector<cloth::Vec3s>>& positions() const { return frames_; }  // [frame][cloth]
  // The colliders at frame f's poses (empty set without colliders).
  collision::ColliderSet colliders(int f) const;
  Bounds bounds() const;
  // The action at frame f: the cloths' bounds plus every collider that reaches into them (grown by half the
  // cloths' size on each side), so a character's body shows but a distant floor or wall does not.
  Bounds action_bounds(int f) const;

 private:
  std::vector<RenderMesh> meshes_;
  std::vector<std::vector<cloth::Vec3s>> frames_;
  collision::ColliderSetPtr colliders_;
  std::vector<std::vector<collision::Transform>> poses_;  // [frame][collider]
};

struct RenderReport {
  int frames = 0;             // frames written, frame_00000.png to frame_<frames - 1>.png
  double ms_per_frame = 0.0;  // wall time of rendering + PNG writing, per frame
  bool stopped = false;       // `stop` was set before every frame was written
};

// Memory (bytes) a render of `frames` recorded frames of `vertices` cloth vertices and `colliders` colliders
// takes at most: the recording's positions (24 bytes per vertex and frame) and poses (128 bytes per collider
// and frame), and per image pixel kBytesPerPixel for the supersampled colour and depth-stencil buffers
// (8 x supersample^2), the image, the PNG encoder's working copies and the renderer's span buffers.
constexpr double kBytesPerPixel = 24.0;
double render_memory_bytes(const RenderSettings& settings, double frames, double vertices, double colliders);

// Renders `rec` into `out` (see above): out/render/frame_NNNNN.png (frame 0 to rec.frames() - 1). Deletes
// nothing: the caller owns `out` and its earlier files. `fps`: frames per second of the rendered frames (the
// camera's tracking is smoothed over time). `stop` (a Ctrl-C flag): checked before each frame; once set, no
// further frame is written and the report says `stopped`.
RenderReport render_recording(const std::string& out, const Recording& rec, const RenderSettings& settings,
                              double fps, const volatile std::sig_atomic_t* stop = nullptr);

}  // namespace loom::render
