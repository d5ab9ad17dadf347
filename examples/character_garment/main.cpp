// A cape skinned to a mocap skeleton (a BVH clip) with automatic weights, driven by a game loop with
// jittering frame times through loom::characters::GarmentInstance. Draws nothing: it writes the cape's
// positions into its own vertex buffer every frame and exits 0 when every position is finite and the cape
// stays on the body (each vertex within its max distance of its skinned position, plus the distance the body
// covers in one step).
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "loom/characters/GarmentInstance.h"
#include "loom/characters/Motion.h"
#include "loom/cloth/ClothMesh.h"

int main(int argc, char** argv) {
  using namespace loom;
  using characters::Affine;
  if (argc < 2) {
    std::fprintf(stderr, "usage: character_garment <clip.bvh>\n");
    return 2;
  }
  const characters::Motion motion = characters::Motion::load(argv[1]);
  std::vector<characters::Transform> joints;
  motion.pose(0.0, joints);
  const int neck = motion.find("Neck"), hips = motion.find("Hips");
  if (neck < 0 || hips < 0) {
    std::fprintf(stderr, "%s: the skeleton has no Neck or Hips joint\n", argv[1]);
    return 1;
  }
  // The cape: 0.4 m wide, from just below the neck down past the hips, 12 cm behind the spine.
  const cloth::Vec3 top = joints[neck].translation(), low = joints[hips].translation();
  cloth::GridSpec grid;
  grid.size_u = 0.4;
  grid.size_v = top.y() - low.y() + 0.15;
  grid.nodes_u = 9;
  grid.nodes_v = 15;
  grid.plane = cloth::GridPlane::kXY;
  grid.origin = cloth::Vec3(top.x() - 0.2, top.y() - 0.05 - grid.size_v, top.z() - 0.12);
  const auto mesh = cloth::ClothMesh::grid(grid);

  // Automatic weights from the nearest bones at the first pose; bone b is joint b.
  std::vector<std::string> names;
  std::vector<Affine> pose;
  std::vector<int> parents;
  for (int j = 0; j < motion.num_joints(); ++j) {
    names.push_back(motion.joints()[j].name);
    pose.emplace_back(joints[j].matrix());
    parents.push_back(motion.joints()[j].parent);
  }
  characters::Skin skin = characters::Skin::automatic(mesh->rest_positions(), names, pose, parents);

  // Max distance 0 along the top row (skinned), growing to 0.25 m at the hem; a backstop 1 cm behind.
  characters::GarmentSettings settings;
  settings.material = cloth::material_preset("cotton");
  const double y_top = grid.origin.y() + grid.size_v;
  for (const cloth::Vec3& p : mesh->rest_positions()) {
    settings.constraints.max_distance.push_back(0.25 * (y_top - p.y()) / grid.size_v);
    settings.constraints.backstop_distance.push_back(0.01);
  }
  settings.linear_inertia = 0.5;  // a running character's cape streams out half as far
  characters::GarmentInstance cape(mesh->rest_positions(), mesh->triangles(), skin, settings, pose, argv[1]);

  // The game loop: frame times jitter between 1/200 s and 1/25 s.
  std::vector<float> vertex_buffer(6 * cape.num_vertices());  // interleaved position + normal
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> frame_time(1.0 / 200.0, 1.0 / 25.0);
  const double duration = std::min(3.0, motion.duration());
  double t = 0.0, worst = 0.0;
  int frames = 0;
  while (t < duration) {
    const double dt = frame_time(rng);
    t += dt;
    motion.pose(t, joints);
    for (int j = 0; j < motion.num_joints(); ++j) pose[j] = Affine(joints[j].matrix());
    cape.set_pose(pose);
    cape.step(dt);
    cape.write_positions(vertex_buffer.data(), 6);
    cape.write_normals(vertex_buffer.data() + 3, 6);
    ++frames;
    for (int i = 0; i < cape.num_vertices(); ++i) {
      const float* v = vertex_buffer.data() + 6 * i;
      const cloth::Vec3 x(v[0], v[1], v[2]);
      if (!x.allFinite()) {
        std::fprintf(stderr, "frame %d: vertex %d is not finite\n", frames, i);
        return 1;
      }
      // The buffer holds the cape one step (1/240 s) behind the frame: allow the body's motion in a step.
      worst = std::max(worst, (x - cape.skinned()[i]).norm() - settings.constraints.max_distance[i]);
    }
  }
  std::printf(
      "character_garment: %d frames over %.2f s of %s, %ld steps; worst excess over the max distance "
      "%.4f m\n",
      frames, t, argv[1], cape.steps(), worst);
  if (worst > 0.05) {
    std::fprintf(stderr, "the cape left the body: %.3f m beyond its max distance\n", worst);
    return 1;
  }
  return 0;
}
