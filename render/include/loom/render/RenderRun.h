#pragma once
// `loom run --render`: keeps the positions of every rendered frame while the simulation runs, then (so
// the camera can be framed on the whole motion) renders DIR/render/frame_00000.png ... (numbered by
// rendered frame), encodes DIR/render.mp4 (H.264, yuv420p) and a short DIR/render.gif preview (first
// 4 s, 15 fps, 320 px wide) with ffmpeg.
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
  int frames = 0;
  double ms_per_frame = 0.0;  // wall time of rendering + PNG writing, per frame
  std::string mp4, gif;       // empty when not written
};

// Renders `rec` into `out` (see above): out/render/frame_NNNNN.png (frame 0 to rec.frames() - 1),
// out/render.mp4 and out/render.gif. Deletes nothing: the caller owns `out` and its earlier files. `fps`:
// frames per second of the video (the rendered frames' rate). `video`: also run ffmpeg (throws loom::Error
// when ffmpeg is missing or fails). `staging`: a private folder (mode 0700, made fresh by the caller, e.g.
// OutputFolder::claim_private_folder) where ffmpeg writes each file before it is renamed into place; empty:
// one is made by mkdtemp inside `out` and removed after. ffmpeg runs as a child that dies with this process
// (PR_SET_PDEATHSIG): a loom killed by a signal leaves no ffmpeg running.
RenderReport render_recording(const std::string& out, const Recording& rec, const RenderSettings& settings,
                              double fps, bool video = true, const std::string& staging = "");

}  // namespace loom::render
