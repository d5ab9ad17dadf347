#pragma once
// The garment tests' cape: a 0.5 m x 0.6 m grid in the plane z = -0.15 behind a two-bone spine (hips at
// y = 1.0 m, neck at 1.6 m), skinned with automatic weights, max distance 0.5 (1.6 m - y): 0 at the neck
// line, 0.3 m at the hem.
#include <vector>

#include "loom/characters/GarmentInstance.h"
#include "loom/cloth/ClothMesh.h"

namespace loom::test {

struct TestCape {
  cloth::Vec3s bind;
  std::vector<cloth::Tri> tris;
  characters::Skin skin;
  characters::GarmentSettings settings;
  std::vector<characters::Affine> bind_pose;  // the spine's two bones at the bind pose
};

struct TestCapeOptions {
  int nodes_u = 11, nodes_v = 13;
  double backstop = -1.0;  // m, per-vertex backstop distance (< 0: none)
  // A coat fabric (bending 1e-4 N m): the default thin fabric (1e-5 N m) buckles at the grid's scale when
  // the cape is compressed, and buckling amplifies any difference (even rounding) by about 10x per 0.1 s,
  // so comparisons between runs need a garment that is not chaotic over the clip.
  bool coat = true;
  double damping = 0.05;  // s
};

inline TestCape make_test_cape(const TestCapeOptions& o = {}) {
  TestCape c;
  cloth::GridSpec g;
  g.size_u = 0.5;
  g.size_v = 0.6;
  g.nodes_u = o.nodes_u;
  g.nodes_v = o.nodes_v;
  g.plane = cloth::GridPlane::kXY;
  g.origin = cloth::Vec3(-0.25, 1.0, -0.15);
  auto mesh = cloth::ClothMesh::grid(g);
  c.bind = mesh->rest_positions();
  c.tris = mesh->triangles();
  c.bind_pose.assign(2, characters::Affine::Identity());
  c.bind_pose[0].translation() = cloth::Vec3(0, 1.0, 0);
  c.bind_pose[1].translation() = cloth::Vec3(0, 1.6, 0);
  c.skin = characters::Skin::automatic(c.bind, {"hips", "neck"}, c.bind_pose, {-1, 0}, 2, "cape");
  for (const cloth::Vec3& p : c.bind) {
    c.settings.constraints.max_distance.push_back(0.5 * (1.6 - p.y()));
    if (o.backstop >= 0.0) c.settings.constraints.backstop_distance.push_back(o.backstop);
  }
  if (o.coat) c.settings.material.bend_weft = c.settings.material.bend_warp = 1e-4;
  c.settings.material.damping = o.damping;
  return c;
}

}  // namespace loom::test
