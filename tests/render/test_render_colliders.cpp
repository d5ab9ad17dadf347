// Colliders in rendered images: a sphere collider appears where it projects, in the collider colour (not
// cloth, not ground, not sky), its pose is the one given (moving it moves it in the image), a cloth in
// front of it hides it, and a horizontal plane collider becomes the ground.
#include <gtest/gtest.h>
#include <stb_image.h>

#include <cstdlib>
#include <filesystem>
#include <memory>

#include "TestDir.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/render/Renderer.h"

namespace loom::render {
namespace {

using cloth::Vec2;
using cloth::Vec3;

// Slate-teal (0.32, 0.60, 0.58) lit: green and blue well above red and close to each other. Sky has blue
// well above green, ground is grey, cloth is red.
bool is_collider(const std::array<uint8_t, 3>& c) {
  return c[1] > 1.4 * c[0] && c[2] > 1.3 * c[0] && std::abs(int(c[1]) - int(c[2])) < 30;
}
bool is_cloth(const std::array<uint8_t, 3>& c) { return c[0] > 30 && c[0] > 1.8 * c[1] && c[0] > 1.8 * c[2]; }

collision::Collider sphere(const Vec3& at, double r) {
  collision::Collider c;
  c.name = "ball";
  c.shape.type = collision::ShapeType::sphere;
  c.shape.radius = r;
  c.curr.translation() = at;
  c.prev = c.curr;
  return c;
}

struct Scene {
  std::shared_ptr<const cloth::ClothMesh> mesh;
  std::unique_ptr<Renderer> r;
  explicit Scene(const Vec3& cloth_origin, bool vertical = false) {
    cloth::GridSpec g;
    if (vertical) g.plane = cloth::GridPlane::kXY;
    g.nodes_u = g.nodes_v = 5;
    g.size_u = g.size_v = 0.4;
    g.origin = cloth_origin;
    mesh = cloth::ClothMesh::grid(g);
    RenderMesh rm;
    rm.triangles = mesh->triangles();
    RenderSettings s;
    s.width = 200;
    s.height = 150;
    s.camera = Camera{Vec3(0.0, 1.2, 3.0), Vec3(0, 0.8, 0), 40.0};
    r = std::make_unique<Renderer>(s, std::vector<RenderMesh>{rm});
  }
};

TEST(RenderColliders, SphereAppearsAtItsProjectedPositionAndFollowsItsPose) {
  Scene sc(Vec3(-1.4, 1.6, -0.2));  // cloth out of the way, upper left
  collision::ColliderSet set{sphere(Vec3(0.3, 0.8, 0.0), 0.25)};
  Bounds b;
  b.add(Vec3(-1.5, 0.0, -1.0));
  b.add(Vec3(1.5, 2.0, 1.0));
  sc.r->frame(b, &set);
  for (const Vec3& centre : {Vec3(0.3, 0.8, 0.0), Vec3(-0.4, 0.6, 0.2)}) {
    set[0].curr.translation() = centre;
    const Image img = sc.r->render({&sc.mesh->rest_positions()}, &set);
    const Vec2 c = sc.r->project(centre);
    const double rad_px = (sc.r->project(centre + Vec3(0.25, 0, 0)) - c).norm();
    ASSERT_GT(rad_px, 8.0);
    // Inside the disc (0.6 radius): collider colour; a ring at 1.6 radii: not.
    int in = 0, in_col = 0, out = 0, out_col = 0;
    for (int a = 0; a < 24; ++a) {
      const Vec2 dir(std::cos(a * 0.2618), std::sin(a * 0.2618));
      for (double f : {0.0, 0.3, 0.6}) {
        const Vec2 p = c + f * rad_px * dir;
        ++in;
        in_col += is_collider(img.at(int(p.x()), int(p.y())));
      }
      const Vec2 p = c + 1.6 * rad_px * dir;
      ++out;
      out_col += is_collider(img.at(int(p.x()), int(p.y())));
    }
    EXPECT_EQ(in_col, in) << "at " << centre.transpose();
    EXPECT_EQ(out_col, 0) << "at " << centre.transpose();
  }
  // Without the collider set nothing collider-coloured is drawn.
  const Image none = sc.r->render({&sc.mesh->rest_positions()});
  int n = 0;
  for (int y = 0; y < none.height; ++y)
    for (int x = 0; x < none.width; ++x) n += is_collider(none.at(x, y));
  EXPECT_EQ(n, 0);
}

TEST(RenderColliders, ClothInFrontHidesTheColliderAndAGroundPlaneMovesTheGround) {
  Scene sc(Vec3(-0.2, 0.6, 0.5), true);  // a vertical 0.4 m square between the camera and the sphere
  collision::ColliderSet set{sphere(Vec3(0.0, 0.8, 0.0), 0.35)};
  collision::Collider ground;
  ground.shape.type = collision::ShapeType::plane;
  ground.curr.translation() = Vec3(0, 0.3, 0);
  set.push_back(ground);
  Bounds b;
  b.add(Vec3(-1, 0.5, -1));
  b.add(Vec3(1, 1.5, 1));
  sc.r->frame(b, &set);
  EXPECT_DOUBLE_EQ(sc.r->ground(), 0.3);  // the plane's height, not ground_height(b) = 0
  const Image img = sc.r->render({&sc.mesh->rest_positions()}, &set);
  const Vec2 centre = sc.r->project(Vec3(0.0, 0.8, 0.0)), side = sc.r->project(Vec3(0.3, 0.8, 0.18));
  EXPECT_TRUE(is_cloth(img.at(int(centre.x()), int(centre.y()))));     // hidden behind the cloth
  EXPECT_TRUE(is_collider(img.at(int(side.x()) - 1, int(side.y()))));  // beside it: seen
  // The ground plane collider itself is not drawn as a collider: below the ball, the ground's grey.
  const Vec2 floor = sc.r->project(Vec3(0.8, 0.3, 0.8));
  EXPECT_FALSE(is_collider(img.at(int(floor.x()), int(floor.y()))));
}

// End to end: `loom run --render` on a scene with a sphere collider shows it in the frames.
TEST(RenderColliders, LoomRunRenderShowsTheScenesColliders) {
  namespace fs = std::filesystem;
  const fs::path out = loom::test::test_dir() / "colliders";
  fs::remove_all(out);
  const std::string cmd = std::string(LOOM_BINARY) + " run " + LOOM_SOURCE_DIR +
                          "/scenes/sphere_spin.json --frames 2 --render --out " + out.string() +
                          " --set cloths.0.mesh.nodes=[9,9] --set 'output={\"formats\": [], \"render\": "
                          "{\"width\": 160, \"height\": 120}}' >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  int w = 0, h = 0, n = 0;
  unsigned char* data = stbi_load((out / "render" / "frame_00002.png").string().c_str(), &w, &h, &n, 3);
  ASSERT_NE(data, nullptr);
  int collider = 0;
  for (int i = 0; i < w * h; ++i) collider += is_collider({data[3 * i], data[3 * i + 1], data[3 * i + 2]});
  stbi_image_free(data);
  EXPECT_GT(collider, w * h / 100);
}

}  // namespace
}  // namespace loom::render
