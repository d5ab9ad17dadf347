#pragma once
// Offscreen cloth renderer: Mesa's software OpenGL through OSMesa (no display, no GPU). Fixed-function GL:
// two-sided cloth (Lambert per vertex on the side facing the camera: ambient + key light + dim headlight,
// front and back colours) modulated by a warp/weft check texture laid out in the
// cloth's material coordinates (TriangleFrame::rest_uv, so checks follow the weave), a checkered ground
// plane, colliders (slate-teal, untextured; a horizontal plane collider is the ground), a planar projected
// shadow (stencilled, so overlapping cloth does not darken twice) and a sky gradient. Images are rendered at
// `supersample` x the size and box-filtered down.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "loom/cloth/Types.h"
#include "loom/collision/Collider.h"

namespace loom::render {

struct Camera {
  cloth::Vec3 eye{0.0, 1.5, 3.0};     // m
  cloth::Vec3 target{0.0, 1.0, 0.0};  // m
  double fov_deg = 40.0;              // vertical field of view, degrees
};

struct RenderSettings {
  int width = 640, height = 480;  // px, of the written image
  int supersample = 2;            // rendered at this multiple, then averaged down (anti-aliasing)
  std::optional<Camera> camera;   // empty: framed automatically on the bounds given to frame()
  double check_size = 0.05;       // m, side of one warp/weft check
};

// One cloth as drawn: triangles, per-corner material coordinates (m) and a base colour (0..1).
struct RenderMesh {
  std::vector<cloth::Tri> triangles;
  std::vector<std::array<cloth::Vec2, 3>> corner_uv;  // m; empty: no checks
  cloth::Vec3 color{0.80, 0.22, 0.18};
};

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  // row-major, top row first, 3 bytes per pixel
  std::array<uint8_t, 3> at(int x, int y) const {
    const size_t i = 3 * (size_t(y) * width + x);
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

// Axis-aligned bounds of everything to be seen (m).
struct Bounds {
  cloth::Vec3 lo = cloth::Vec3::Constant(1e300), hi = cloth::Vec3::Constant(-1e300);
  void add(const cloth::Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  bool empty() const { return lo.x() > hi.x(); }
};

// A camera that sees all of `b` from the front-right, slightly above, with some margin.
Camera auto_camera(const Bounds& b, double aspect, double fov_deg = 35.0);
// The ground height used for `b`: y = 0 when everything is above it, else just below the lowest point.
double ground_height(const Bounds& b);

class Renderer {
 public:
  // Creates the OSMesa context; throws loom::Error when software GL is unavailable.
  Renderer(RenderSettings settings, std::vector<RenderMesh> meshes);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Fixes camera (unless the settings name one) and ground from the bounds of the whole animation; a
  // horizontal plane collider in `colliders` puts the ground at its height.
  void frame(const Bounds& b, const collision::ColliderSet* colliders = nullptr);
  // One image of the meshes at these positions (one pointer per mesh), with the colliders at their `curr`
  // poses (the set's shapes are tessellated on first use and whenever they change).
  Image render(const std::vector<const cloth::Vec3s*>& positions,
               const collision::ColliderSet* colliders = nullptr);
  // Moves the camera (eye and target together, same direction and distance) so that it looks at `target`
  // (m); nothing happens when the settings name a camera. render_recording tracks the action with it.
  void look_at(const cloth::Vec3& target);
  const Camera& camera() const { return camera_; }
  // Pixel (x right, y down, of the written image) where the world point `p` appears.
  cloth::Vec2 project(const cloth::Vec3& p) const;
  double ground() const { return ground_; }

 private:
  struct Gl;
  std::unique_ptr<Gl> gl_;
  RenderSettings settings_;
  std::vector<RenderMesh> meshes_;
  Camera camera_;
  double ground_ = 0.0;  // m
  double extent_ = 1.0;  // m, size of the framed scene (ground plane size)
  cloth::Vec3 center_ = cloth::Vec3::Zero();
};

// PNG through stb_image_write; throws loom::Error naming the file on failure.
void write_png(const std::string& path, const Image& image);
// The bytes of `image` as a PNG file, for a caller that writes them through its own safe open.
std::string encode_png(const Image& image);

}  // namespace loom::render
