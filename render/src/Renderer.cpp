#include "loom/render/Renderer.h"

#include <GL/osmesa.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <optional>

#include "gl/ColliderShapes.h"
#include "gl/Draw.h"
#include "loom/cloth/Error.h"

namespace loom::render {

using cloth::Vec2;
using cloth::Vec3;
using Mat4 = Eigen::Matrix4d;

namespace {

using gl::kPi;
using gl::Mat4;
const Vec3 kToLight = gl::to_light();

}  // namespace

struct Renderer::Gl {
  OSMesaContext ctx = nullptr;
  std::vector<uint8_t> buffer;  // RGBA, bottom row first
  int w = 0, h = 0;
  gl::Textures textures;
  gl::ColliderShapes colliders;
};

Renderer::Renderer(RenderSettings settings, std::vector<RenderMesh> meshes)
    : gl_(std::make_unique<Gl>()), settings_(settings), meshes_(std::move(meshes)) {
  if (settings_.width < 1 || settings_.height < 1 || settings_.supersample < 1)
    throw Error("", "render", "image size and supersampling must be >= 1");
  gl_->w = settings_.width * settings_.supersample;
  gl_->h = settings_.height * settings_.supersample;
  // Mesa keeps a shader cache in $XDG_CACHE_HOME or ~/.cache (following links there): a render writes
  // nothing outside its output folder, so the cache is off (Mesa reads these when a context is made;
  // MESA_GLSL_CACHE_DISABLE for older releases).
  ::setenv("MESA_SHADER_CACHE_DISABLE", "true", 1);
  ::setenv("MESA_GLSL_CACHE_DISABLE", "true", 1);
  gl_->ctx = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
  if (!gl_->ctx) throw Error("", "render", "cannot create an OSMesa (software OpenGL) context");
  gl_->buffer.resize(size_t(gl_->w) * gl_->h * 4);
  if (!OSMesaMakeCurrent(gl_->ctx, gl_->buffer.data(), GL_UNSIGNED_BYTE, gl_->w, gl_->h))
    throw Error("", "render",
                "cannot bind the OSMesa context to a " + std::to_string(gl_->w) + "x" +
                    std::to_string(gl_->h) + " image");
  gl_->textures = gl::create_textures();
  if (settings_.camera) camera_ = *settings_.camera;
}

Renderer::~Renderer() {
  if (gl_ && gl_->ctx) OSMesaDestroyContext(gl_->ctx);
}

void Renderer::frame(const Bounds& b, const collision::ColliderSet* colliders) {
  if (b.empty()) return;
  ground_ = ground_height(b);
  if (colliders)
    if (const std::optional<double> g = gl::ground_plane(*colliders)) ground_ = *g;
  Bounds seen = b;
  // Where the shadow of the cloth's centre falls belongs in the picture (the whole footprint would push the
  // camera far back for cloth hanging high above the ground).
  const Vec3 mid = 0.5 * (b.lo + b.hi);
  seen.add(mid - kToLight * (mid.y() - ground_) / kToLight.y());
  center_ = 0.5 * (seen.lo + seen.hi);
  extent_ = std::max((seen.hi - seen.lo).norm(), 0.1);
  if (!settings_.camera) camera_ = auto_camera(seen, double(settings_.width) / settings_.height);
}

void Renderer::look_at(const Vec3& target) {
  if (settings_.camera) return;
  const Vec3 shift = target - camera_.target;
  camera_.target += shift;
  camera_.eye += shift;
}

cloth::Vec2 Renderer::project(const Vec3& p) const {
  const double dist = (camera_.eye - camera_.target).norm();
  const Mat4 pv = gl::perspective(camera_.fov_deg, double(settings_.width) / settings_.height,
                                  std::max(1e-3, 0.02 * dist), dist + 8.0 * extent_) *
                  gl::look_at(camera_.eye, camera_.target, Vec3(0, 1, 0));
  const Eigen::Vector4d c = pv * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
  return Vec2((0.5 * c.x() / c.w() + 0.5) * settings_.width, (0.5 - 0.5 * c.y() / c.w()) * settings_.height);
}

Image Renderer::render(const std::vector<const cloth::Vec3s*>& positions,
                       const collision::ColliderSet* colliders) {
  if (positions.size() != meshes_.size()) throw Error("", "render", "one position array per mesh expected");
  OSMesaMakeCurrent(gl_->ctx, gl_->buffer.data(), GL_UNSIGNED_BYTE, gl_->w, gl_->h);
  gl::DrawParams p;
  p.camera = camera_;
  p.aspect = double(settings_.width) / settings_.height;
  p.ground = ground_;
  p.extent = extent_;
  p.center = center_;
  p.check_size = settings_.check_size;
  p.viewport_w = gl_->w;
  p.viewport_h = gl_->h;
  std::vector<collision::ColliderMesh> posed;
  if (colliders) {
    gl_->colliders.update(*colliders, 6.0 * extent_);
    posed = gl_->colliders.posed(*colliders);
  }
  gl::draw_scene(p, gl_->textures, meshes_, positions, posed);
  glFinish();

  // Box-filter down by the supersampling factor; OSMesa's rows run bottom-up.
  const int s = settings_.supersample;
  Image img;
  img.width = settings_.width;
  img.height = settings_.height;
  img.rgb.resize(size_t(img.width) * img.height * 3);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int k = 0; k < 3; ++k) {
        int sum = 0;
        for (int dy = 0; dy < s; ++dy)
          for (int dx = 0; dx < s; ++dx) {
            const int sy = (img.height - 1 - y) * s + dy, sx = x * s + dx;
            sum += gl_->buffer[4 * (size_t(sy) * gl_->w + sx) + k];
          }
        img.rgb[3 * (size_t(y) * img.width + x) + k] = static_cast<uint8_t>((sum + s * s / 2) / (s * s));
      }
  return img;
}

}  // namespace loom::render
