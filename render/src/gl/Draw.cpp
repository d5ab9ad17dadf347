#include "gl/Draw.h"

#include <GL/glext.h>

#include <algorithm>
#include <cmath>

namespace loom::render::gl {

using cloth::Vec2;
using cloth::Vec3;

namespace {

const Vec3 kToLight = to_light();

const float kSkyTop[3] = {0.52f, 0.66f, 0.84f}, kHorizon[3] = {0.86f, 0.89f, 0.93f};

}  // namespace

Mat4 perspective(double fov_deg, double aspect, double znear, double zfar) {
  const double f = 1.0 / std::tan(0.5 * fov_deg * kPi / 180.0);
  Mat4 m = Mat4::Zero();
  m(0, 0) = f / aspect;
  m(1, 1) = f;
  m(2, 2) = (zfar + znear) / (znear - zfar);
  m(2, 3) = 2.0 * zfar * znear / (znear - zfar);
  m(3, 2) = -1.0;
  return m;
}

Mat4 look_at(const Vec3& eye, const Vec3& target, Vec3 up) {
  const Vec3 f = (target - eye).normalized();
  if (std::abs(f.dot(up)) > 0.999) up = Vec3(0, 0, 1);
  const Vec3 s = f.cross(up).normalized(), u = s.cross(f);
  Mat4 m = Mat4::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

namespace {

// Projects points along the light direction onto the plane y = g (planar shadow, Blinn 1988 "Me and my
// (fake) shadow").
Mat4 shadow_matrix(const Vec3& l, double g) {
  Mat4 m = Mat4::Identity();
  m(0, 1) = -l.x() / l.y();
  m(0, 3) = l.x() / l.y() * g;
  m(1, 1) = 0.0;
  m(1, 3) = g;
  m(2, 1) = -l.z() / l.y();
  m(2, 3) = l.z() / l.y() * g;
  return m;
}

// A woven check: warp and weft stripes of one check each per period, darker where they cross, with a
// faint thread line at every stripe edge. One texture period = two checks.
std::vector<uint8_t> check_texture(int n) {
  std::vector<uint8_t> t(size_t(n) * n * 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const bool su = i < n / 2, sv = j < n / 2;
      double v = 1.0 - 0.26 * su - 0.26 * sv;
      if (i % (n / 2) == 0 || j % (n / 2) == 0) v *= 0.9;
      for (int k = 0; k < 3; ++k)
        t[3 * (size_t(j) * n + i) + k] = static_cast<uint8_t>(std::lround(255.0 * v));
    }
  return t;
}

std::vector<uint8_t> ground_texture(int n) {
  std::vector<uint8_t> t(size_t(n) * n * 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const bool odd = (i < n / 2) != (j < n / 2);
      const uint8_t v = odd ? 178 : 204;
      for (int k = 0; k < 3; ++k) t[3 * (size_t(j) * n + i) + k] = static_cast<uint8_t>(v - (k == 2 ? 6 : 0));
    }
  return t;
}

GLuint make_texture(const std::vector<uint8_t>& rgb, int n) {
  GLuint id = 0;
  glGenTextures(1, &id);
  glBindTexture(GL_TEXTURE_2D, id);
  glTexParameteri(GL_TEXTURE_2D, GL_GENERATE_MIPMAP, GL_TRUE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB, n, n, 0, GL_RGB, GL_UNSIGNED_BYTE, rgb.data());
  return id;
}

}  // namespace

Textures create_textures() {
  return Textures{make_texture(check_texture(64), 64), make_texture(ground_texture(64), 64)};
}

namespace {

// Sky gradient (screen space, no depth).
void draw_sky() {
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_LIGHTING);
  glDisable(GL_TEXTURE_2D);
  glMatrixMode(GL_PROJECTION);
  glLoadIdentity();
  glMatrixMode(GL_MODELVIEW);
  glLoadIdentity();
  glBegin(GL_QUADS);
  glColor3fv(kHorizon);
  glVertex2f(-1, -1);
  glVertex2f(1, -1);
  glColor3fv(kSkyTop);
  glVertex2f(1, 1);
  glVertex2f(-1, 1);
  glEnd();
}

// Projection and view of `p.camera`; depth test on. Returns the camera's distance to its target (m).
double set_camera(const DrawParams& p) {
  const double dist = (p.camera.eye - p.camera.target).norm();
  const double far = dist + 8.0 * p.extent, near = std::max(1e-3, 0.02 * dist);
  const Mat4 proj = perspective(p.camera.fov_deg, p.aspect, near, far);
  const Mat4 view = look_at(p.camera.eye, p.camera.target, Vec3(0, 1, 0));
  glMatrixMode(GL_PROJECTION);
  glLoadMatrixd(proj.data());
  glMatrixMode(GL_MODELVIEW);
  glLoadMatrixd(view.data());
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);

  return dist;
}

// Fog towards the horizon colour so the ground's far edge fades out.
void set_fog(const DrawParams& p, double dist) {
  glEnable(GL_FOG);
  glFogi(GL_FOG_MODE, GL_LINEAR);
  const float fog_color[4] = {kHorizon[0], kHorizon[1], kHorizon[2], 1.0f};
  glFogfv(GL_FOG_COLOR, fog_color);
  glFogf(GL_FOG_START, static_cast<float>(dist + 0.5 * p.extent));
  glFogf(GL_FOG_END, static_cast<float>(dist + 4.0 * p.extent));
}

// Ground: a checkered square (0.5 m checks) under the scene; marks stencil 1.
void draw_ground(const DrawParams& p, const Textures& t) {
  const double half = 6.0 * p.extent, g = p.ground;
  glEnable(GL_STENCIL_TEST);
  glStencilFunc(GL_ALWAYS, 1, 0xff);
  glStencilOp(GL_KEEP, GL_KEEP, GL_REPLACE);
  glEnable(GL_TEXTURE_2D);
  glBindTexture(GL_TEXTURE_2D, t.ground);
  glTexEnvi(GL_TEXTURE_ENV, GL_TEXTURE_ENV_MODE, GL_MODULATE);
  glColor3f(1.0f, 1.0f, 1.0f);
  glBegin(GL_QUADS);
  const double x0 = p.center.x() - half, x1 = p.center.x() + half, z0 = p.center.z() - half,
               z1 = p.center.z() + half;
  const double tex = 1.0;  // m per texture period (two 0.5 m checks)
  glTexCoord2d(x0 / tex, z0 / tex);
  glVertex3d(x0, g, z0);
  glTexCoord2d(x0 / tex, z1 / tex);
  glVertex3d(x0, g, z1);
  glTexCoord2d(x1 / tex, z1 / tex);
  glVertex3d(x1, g, z1);
  glTexCoord2d(x1 / tex, z0 / tex);
  glVertex3d(x1, g, z0);
  glEnd();
  glDisable(GL_TEXTURE_2D);
}

// Per-corner arrays of every cloth: positions, colours (two-sided Lambert) and material coordinates.
struct ClothArrays {
  std::vector<std::vector<float>> P, C, T;
};

ClothArrays cloth_arrays(const DrawParams& p, const std::vector<RenderMesh>& meshes,
                         const std::vector<const cloth::Vec3s*>& positions) {
  ClothArrays a;
  std::vector<std::vector<float>>& P = a.P;
  std::vector<std::vector<float>>& C = a.C;
  std::vector<std::vector<float>>& T = a.T;
  P.resize(meshes.size()), C.resize(meshes.size()), T.resize(meshes.size());
  for (size_t m = 0; m < meshes.size(); ++m) {
    const cloth::Vec3s& x = *positions[m];
    const RenderMesh& mesh = meshes[m];
    cloth::Vec3s vn(x.size(), Vec3::Zero());
    for (const cloth::Tri& t : mesh.triangles) {
      const Vec3 n = (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);  // area-weighted
      for (int k = 0; k < 3; ++k) vn[t[k]] += n;
    }
    for (Vec3& n : vn) n = n.norm() > 0 ? Vec3(n.normalized()) : Vec3(0, 1, 0);
    const double period = 2.0 * p.check_size;
    const Vec3 back = 0.75 * mesh.color + Vec3::Constant(0.2);
    for (size_t ti = 0; ti < mesh.triangles.size(); ++ti) {
      // Two-sided shading: the side facing the camera is lit with its own normal (front colour on the
      // side the triangle normal points to, back colour on the other).
      const cloth::Tri& t = mesh.triangles[ti];
      const Vec3 fn = (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);
      const Vec3 centroid = (x[t[0]] + x[t[1]] + x[t[2]]) / 3.0;
      const bool front = fn.dot(p.camera.eye - centroid) >= 0.0;
      for (int k = 0; k < 3; ++k) {
        const int v = t[k];
        const Vec3 n = front ? vn[v] : Vec3(-vn[v]);
        const Vec3 to_eye = (p.camera.eye - x[v]).normalized();
        // Lambert: ambient + key light + a dim headlight so the side away from the key keeps its shape.
        const double light =
            0.30 + 0.75 * std::max(0.0, n.dot(kToLight)) + 0.30 * std::max(0.0, n.dot(to_eye));
        const Vec3 col = (front ? mesh.color : back) * light;
        for (int c = 0; c < 3; ++c) {
          P[m].push_back(static_cast<float>(x[v][c]));
          C[m].push_back(static_cast<float>(std::min(1.0, col[c])));
        }
        const Vec2 uv = mesh.corner_uv.empty() ? Vec2::Zero() : mesh.corner_uv[ti][k];
        T[m].push_back(static_cast<float>(uv.x() / period));
        T[m].push_back(static_cast<float>(uv.y() / period));
      }
    }
  }
  return a;
}

// Colliders: per-corner positions (CP) and colours (CC), lit like the cloth with the shape's own normals
// (flipped on faces seen from behind: open meshes and tilted planes are two-sided).
void collider_arrays(const DrawParams& p, const std::vector<collision::ColliderMesh>& colliders,
                     std::vector<float>& CP, std::vector<float>& CC) {
  const Vec3 collider_color(kColliderColor[0], kColliderColor[1], kColliderColor[2]);
  for (const collision::ColliderMesh& m : colliders)
    for (const cloth::Tri& t : m.triangles) {
      const Vec3 fn = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
      const bool front = fn.dot(p.camera.eye - m.vertices[t[0]]) >= 0.0;
      for (int k = 0; k < 3; ++k) {
        const Vec3& x = m.vertices[t[k]];
        const Vec3 n = front ? m.normals[t[k]] : Vec3(-m.normals[t[k]]);
        const Vec3 to_eye = (p.camera.eye - x).normalized();
        const double light =
            0.30 + 0.75 * std::max(0.0, n.dot(kToLight)) + 0.30 * std::max(0.0, n.dot(to_eye));
        for (int c = 0; c < 3; ++c) {
          CP.push_back(static_cast<float>(x[c]));
          CC.push_back(static_cast<float>(std::min(1.0, collider_color[c] * light)));
        }
      }
    }
}

// Shadow: the cloths and colliders flattened onto the ground (height g) along the light, drawn once per
// ground pixel.
void draw_shadows(const DrawParams& p, double g, const ClothArrays& cloths, const std::vector<float>& CP) {
  const std::vector<std::vector<float>>& P = cloths.P;
  glStencilFunc(GL_EQUAL, 1, 0xff);
  glStencilOp(GL_KEEP, GL_KEEP, GL_INCR);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_FOG);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glColor4f(0.12f, 0.13f, 0.16f, 0.5f);
  glPushMatrix();
  const Mat4 sm = shadow_matrix(kToLight, g + 1e-4 * p.extent);
  glMultMatrixd(sm.data());
  for (size_t m = 0; m < P.size(); ++m) {
    glVertexPointer(3, GL_FLOAT, 0, P[m].data());
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(P[m].size() / 3));
  }
  if (!CP.empty()) {
    glVertexPointer(3, GL_FLOAT, 0, CP.data());
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(CP.size() / 3));
  }
  glPopMatrix();
  glDisable(GL_BLEND);
  glDisable(GL_STENCIL_TEST);
  glEnable(GL_DEPTH_TEST);
  glEnable(GL_FOG);
}

}  // namespace

void draw_scene(const DrawParams& p, const Textures& t, const std::vector<RenderMesh>& meshes,
                const std::vector<const cloth::Vec3s*>& positions,
                const std::vector<collision::ColliderMesh>& colliders) {
  glViewport(0, 0, p.viewport_w, p.viewport_h);
  glClearColor(kHorizon[0], kHorizon[1], kHorizon[2], 1.0f);
  glClearStencil(0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
  draw_sky();
  const double dist = set_camera(p);
  set_fog(p, dist);
  draw_ground(p, t);
  const ClothArrays cloths = cloth_arrays(p, meshes, positions);
  const std::vector<std::vector<float>>& P = cloths.P;
  const std::vector<std::vector<float>>& C = cloths.C;
  const std::vector<std::vector<float>>& T = cloths.T;
  std::vector<float> CP, CC;
  collider_arrays(p, colliders, CP, CC);
  glEnableClientState(GL_VERTEX_ARRAY);
  draw_shadows(p, p.ground, cloths, CP);

  // Colliders: Gouraud, untextured.
  glEnableClientState(GL_COLOR_ARRAY);
  if (!CP.empty()) {
    glVertexPointer(3, GL_FLOAT, 0, CP.data());
    glColorPointer(3, GL_FLOAT, 0, CC.data());
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(CP.size() / 3));
  }

  // Cloth: the colours lit above (Gouraud), modulated by the warp/weft check texture.
  glEnable(GL_TEXTURE_2D);
  glBindTexture(GL_TEXTURE_2D, t.check);
  glEnableClientState(GL_TEXTURE_COORD_ARRAY);
  for (size_t m = 0; m < meshes.size(); ++m) {
    glVertexPointer(3, GL_FLOAT, 0, P[m].data());
    glColorPointer(3, GL_FLOAT, 0, C[m].data());
    glTexCoordPointer(2, GL_FLOAT, 0, T[m].data());
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(P[m].size() / 3));
  }
  glDisableClientState(GL_COLOR_ARRAY);
  glDisableClientState(GL_TEXTURE_COORD_ARRAY);
  glDisableClientState(GL_VERTEX_ARRAY);
  glDisable(GL_TEXTURE_2D);
  glDisable(GL_FOG);
}

}  // namespace loom::render::gl
