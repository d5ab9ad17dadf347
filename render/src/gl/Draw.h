#pragma once
// The GL drawing of a cloth frame, shared by the offscreen Renderer (OSMesa) and the viewer (GLFW):
// sky gradient, checkered ground, projected shadow, two-sided checked cloth. Fixed-function OpenGL 1.x
// calls only; the caller owns the context. Internal to apps/ (not installed).
#include <GL/gl.h>

#include <vector>

#include "loom/collision/ColliderMesh.h"
#include "loom/render/Renderer.h"

namespace loom::render::gl {

using Mat4 = Eigen::Matrix4d;

constexpr double kPi = 3.14159265358979323846;
// Direction towards the key light (it also casts the shadow).
inline cloth::Vec3 to_light() { return cloth::Vec3(0.45, 1.0, 0.35).normalized(); }

Mat4 perspective(double fov_deg, double aspect, double znear, double zfar);
Mat4 look_at(const cloth::Vec3& eye, const cloth::Vec3& target, cloth::Vec3 up);
// Near and far planes used for a camera at `dist` from its target in a scene of size `extent` (m).
inline double near_plane(double dist) { return dist * 0.02 > 1e-3 ? dist * 0.02 : 1e-3; }
inline double far_plane(double dist, double extent) { return dist + 8.0 * extent; }

struct Textures {
  GLuint check = 0, ground = 0;
};
Textures create_textures();  // in the current context

struct DrawParams {
  Camera camera;
  double aspect = 4.0 / 3.0;
  double ground = 0.0;  // m
  double extent = 1.0;  // m
  cloth::Vec3 center = cloth::Vec3::Zero();
  double check_size = 0.05;                // m
  int viewport_w = 640, viewport_h = 480;  // px
};

// Colliders (world meshes, ColliderShapes.h) are drawn in one untextured slate-teal, lit like the cloth,
// and cast shadows too.
constexpr float kColliderColor[3] = {0.32f, 0.60f, 0.58f};
void draw_scene(const DrawParams& p, const Textures& t, const std::vector<RenderMesh>& meshes,
                const std::vector<const cloth::Vec3s*>& positions,
                const std::vector<collision::ColliderMesh>& colliders = {});

}  // namespace loom::render::gl
