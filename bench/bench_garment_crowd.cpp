// loom_bench_garment_crowd: 50 characters, each wearing the same skinned cape (characters::GarmentInstance,
// 9 x 15 nodes, 1/240 s steps) on a CMU clip, one 60 Hz frame per iteration. Character i stands 2 + i m from
// the camera; every fifth plays the clip (phase-shifted), the others hold its first pose. Both crowds run
// in every iteration, timed separately:
//   full: sleep off, stride 1 (every cape simulated at full rate);
//   lod:  sleep on (defaults), set_lod(distance) with the default GarmentLodSettings.
// Counters: us_per_char_full, us_per_char_lod (wall time per character per frame), ratio (full / lod),
// asleep (capes asleep in the lod crowd at the end). 1 OpenMP thread.
//
// BM_GarmentMeshLod: one cape as a coarse 5 x 8 mesh (characters::GarmentMeshLod, levels 1: shown as the
// 9 x 15 curved-face mesh) on the moving clip, twice in every iteration, timed separately: one simulating the
// fine mesh (near), one the coarse mesh and evaluating its curved faces (far). Counters: us_fine, us_coarse
// (wall time per frame), ratio (fine / coarse).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "loom/characters/GarmentInstance.h"
#include "loom/characters/GarmentMeshLod.h"
#include "loom/characters/Motion.h"
#include "loom/cloth/ClothMesh.h"

namespace {

using namespace loom;
using characters::Affine;

constexpr int kCharacters = 50;
constexpr double kFrame = 1.0 / 60.0;

struct Crowd {
  std::vector<characters::GarmentInstance> capes;
  std::vector<Eigen::Isometry3d> place;  // world placement of each character
  std::vector<bool> moving;
  std::vector<int> phase;  // frames
};

// The pose table of the clip at 60 Hz, and the cape of examples/character_garment built on its first pose.
struct Setup {
  std::vector<std::vector<Affine>> poses;
  cloth::Vec3s bind;
  std::vector<cloth::Tri> tris;
  characters::Skin skin;
  characters::GarmentSettings settings;
};

Setup make_setup(int nodes_u = 9, int nodes_v = 15) {
  Setup s;
  const characters::Motion motion = characters::Motion::load(LOOM_SOURCE_DIR "/tests/data/mocap/01_01.bvh");
  std::vector<characters::Transform> joints;
  const int frames = static_cast<int>(std::min(5.0, motion.duration()) / kFrame);
  for (int f = 0; f < frames; ++f) {
    motion.pose(f * kFrame, joints);
    std::vector<Affine> pose;
    for (const auto& j : joints) pose.emplace_back(j.matrix());
    s.poses.push_back(pose);
  }
  motion.pose(0.0, joints);
  const int neck = motion.find("Neck"), hips = motion.find("Hips");
  const cloth::Vec3 top = joints[neck].translation(), low = joints[hips].translation();
  cloth::GridSpec grid;
  grid.size_u = 0.4;
  grid.size_v = top.y() - low.y() + 0.15;
  grid.nodes_u = nodes_u;
  grid.nodes_v = nodes_v;
  grid.plane = cloth::GridPlane::kXY;
  grid.origin = cloth::Vec3(top.x() - 0.2, top.y() - 0.05 - grid.size_v, top.z() - 0.12);
  const auto mesh = cloth::ClothMesh::grid(grid);
  s.bind = mesh->rest_positions();
  s.tris = mesh->triangles();
  std::vector<std::string> names;
  std::vector<int> parents;
  for (int j = 0; j < motion.num_joints(); ++j) {
    names.push_back(motion.joints()[j].name);
    parents.push_back(motion.joints()[j].parent);
  }
  s.skin = characters::Skin::automatic(s.bind, names, s.poses[0], parents);
  s.settings.material = cloth::material_preset("cotton");
  const double y_top = grid.origin.y() + grid.size_v;
  for (const cloth::Vec3& p : s.bind) {
    s.settings.constraints.max_distance.push_back(0.25 * (y_top - p.y()) / grid.size_v);
    s.settings.constraints.backstop_distance.push_back(0.01);
  }
  return s;
}

void placed(const std::vector<Affine>& pose, const Eigen::Isometry3d& place, std::vector<Affine>& out) {
  out.resize(pose.size());
  for (size_t b = 0; b < pose.size(); ++b) out[b] = place * pose[b];
}

Crowd make_crowd(const Setup& s, bool lod) {
  Crowd c;
  characters::GarmentSettings settings = s.settings;
  settings.sleep.enabled = lod;
  std::vector<Affine> pose;
  for (int i = 0; i < kCharacters; ++i) {
    const double distance = 2.0 + i;
    Eigen::Isometry3d place = Eigen::Isometry3d::Identity();
    place.translate(cloth::Vec3(1.5 * (i % 10), 0.0, -distance));
    c.place.push_back(place);
    c.moving.push_back(i % 5 == 0);
    c.phase.push_back(7 * i);
    placed(s.poses[0], place, pose);
    c.capes.emplace_back(s.bind, s.tris, s.skin, settings, pose, "cape");
    if (lod) c.capes.back().set_lod(distance);
  }
  return c;
}

void frame(const Setup& s, Crowd& c, int f, std::vector<Affine>& scratch) {
  for (int i = 0; i < kCharacters; ++i) {
    const int k = c.moving[i] ? (f + c.phase[i]) % static_cast<int>(s.poses.size()) : 0;
    placed(s.poses[k], c.place[i], scratch);
    c.capes[i].set_pose(scratch);
    c.capes[i].step(kFrame);
  }
}

void BM_GarmentCrowd(benchmark::State& state) {
  omp_set_num_threads(1);
  const Setup s = make_setup();
  Crowd full = make_crowd(s, false), lod = make_crowd(s, true);
  std::vector<Affine> scratch;
  int f = 0;
  for (; f < 180; ++f) {  // 3 s: the still capes settle (and the lod crowd's fall asleep)
    frame(s, full, f, scratch);
    frame(s, lod, f, scratch);
  }
  double t_full = 0, t_lod = 0;
  using Clock = std::chrono::steady_clock;
  for (auto _ : state) {
    const auto a = Clock::now();
    frame(s, full, f, scratch);
    const auto b = Clock::now();
    frame(s, lod, f, scratch);
    const auto c = Clock::now();
    ++f;
    t_full += std::chrono::duration<double>(b - a).count();
    t_lod += std::chrono::duration<double>(c - b).count();
  }
  const double n = static_cast<double>(state.iterations()) * kCharacters;
  int asleep = 0;
  for (const auto& g : lod.capes) asleep += g.asleep();
  state.counters["us_per_char_full"] = 1e6 * t_full / n;
  state.counters["us_per_char_lod"] = 1e6 * t_lod / n;
  state.counters["ratio"] = t_lod > 0 ? t_full / t_lod : 0.0;
  state.counters["asleep"] = asleep;
}

BENCHMARK(BM_GarmentCrowd)->Unit(benchmark::kMillisecond)->MinTime(2.0);

void BM_GarmentMeshLod(benchmark::State& state) {
  omp_set_num_threads(1);
  const Setup s = make_setup(5, 8);
  characters::GarmentMeshLod near(s.bind, s.tris, s.skin, s.settings, s.poses[0], {}, "cape");
  characters::GarmentMeshLod far(s.bind, s.tris, s.skin, s.settings, s.poses[0], {}, "cape");
  near.force(true);
  int f = 0;
  auto frame = [&](characters::GarmentMeshLod& g) {
    g.set_pose(s.poses[f % s.poses.size()]);
    g.step(kFrame);
  };
  for (; f < 60; ++f) frame(near), frame(far);  // 1 s: the switch to fine and its blend are behind
  double t_fine = 0, t_coarse = 0;
  using Clock = std::chrono::steady_clock;
  for (auto _ : state) {
    const auto a = Clock::now();
    frame(near);
    const auto b = Clock::now();
    frame(far);
    const auto c = Clock::now();
    ++f;
    t_fine += std::chrono::duration<double>(b - a).count();
    t_coarse += std::chrono::duration<double>(c - b).count();
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["us_fine"] = 1e6 * t_fine / n;
  state.counters["us_coarse"] = 1e6 * t_coarse / n;
  state.counters["ratio"] = t_coarse > 0 ? t_fine / t_coarse : 0.0;
  state.counters["fine_vertices"] = far.num_vertices();
}

BENCHMARK(BM_GarmentMeshLod)->Unit(benchmark::kMillisecond)->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
