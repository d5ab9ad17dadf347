#pragma once
// Hybrid detail on a character scene, shared by the test (CI size) and the bench (full size):
// the cape (0.625 m x 0.75 m, attached along the shoulders) on the CMU 01_01 character held still (the clip
// starts past its end, so its last pose is held) with gravity tilted 30° towards the character's front — the
// character leaning back — so the cape falls onto the back and hips and settles there in contact (air
// drag), simulated (a) coarse and shown as its curved-face surface with `levels` levels, and (b) as a full
// simulation at the refined mesh's resolution (the coarse edge / 2^levels). Distance: point to surface, both
// ways: every fine-simulation vertex to the detail surface and every detail vertex to the fine simulation's
// surface (RMS over both sets, and the max). Also measured: the cost of each (process CPU time: steps plus,
// for (a), the detail surface after every frame), the largest per-frame move of the detail surface over the
// largest per-frame move of the coarse mesh (popping shows as a large ratio), and the largest vertex speed of
// each over the last frame (settled).
#include <algorithm>
#include <cmath>
#include <ctime>
#include <string>
#include <vector>

#include "loom/characters/Character.h"
#include "loom/cloth/CurvedFaces.h"
#include "loom/collision/Distance.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace loom::test {

struct HybridCharacterResult {
  int coarse_vertices = 0, fine_vertices = 0;
  double rms = 0.0, max = 0.0;  // m, detail surface vs fine simulation at the same material points
  double coarse_cpu = 0.0, fine_cpu = 0.0;      // s, process CPU time (coarse: steps + detail surface)
  double worst_move_ratio = 0.0;                // 1, per frame: max detail move / max coarse move
  double coarse_speed = 0.0, fine_speed = 0.0;  // m/s, largest vertex speed over the last frame
  double sag = 0.0;  // m, largest vertex displacement of the fine garment from its start (it did drape)
};

inline nlohmann::json hybrid_character_scene(double resolution, int levels, int frames) {
  nlohmann::json garment = {
      {"type", "cape"}, {"name", "cape"}, {"resolution", resolution},
      {"width", 0.625}, {"length", 0.75}, {"material", {{"preset", "cotton"}, {"damping", 1e-4}}}};
  if (levels > 0) garment["detail"] = {{"method", "curved_faces"}, {"levels", levels}};
  return {{"name", "hybrid_character"},
          {"duration", frames / 60.0},
          {"fps", 60},
          {"gravity", {0, -9.81, 0}},
          {"solver", {{"method", "implicit_euler"}, {"substeps", 4}}},
          {"effects", {{"drag", {{"isotropic", 1.0}}}}},  // kg/(m² s): settles the swing
          {"character",
           {{"bvh", std::string(LOOM_TEST_DATA) + "/mocap/01_01.bvh"},
            {"scale", "auto"},
            {"root_motion", false},
            {"start", 1000.0},  // past the clip's end: the last pose, held (loop off)
            {"garments", {garment}}}}};
}

// Gravity 30° from the vertical towards the character's front (from the cape's centre to the root joint,
// horizontally): the cape lies on the back.
inline void lean_back(scene::Scene& s) {
  std::vector<characters::Transform> pose;
  s.character->motion.pose(0.0, pose);
  const cloth::Vec3s& x = s.setup.cloths[0].mesh->rest_positions();
  cloth::Vec3 centre = cloth::Vec3::Zero();
  for (const cloth::Vec3& p : x) centre += p / static_cast<double>(x.size());
  cloth::Vec3 front = pose[s.character->motion.root()].translation() - centre;
  front.y() = 0.0;
  front.normalize();
  const double a = 30.0 * 3.14159265358979323846 / 180.0;
  s.setup.gravity = 9.81 * (-std::cos(a) * cloth::Vec3::UnitY() + std::sin(a) * front);
}

inline double cpu_seconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

inline HybridCharacterResult measure_hybrid_character(double coarse_resolution, int levels, int frames) {
  HybridCharacterResult r;
  const std::string file = std::string(LOOM_TEST_DATA) + "/hybrid_character.json";  // only names errors
  // (a) coarse + detail.
  scene::Scene coarse_scene =
      scene::parse_scene(hybrid_character_scene(coarse_resolution, levels, frames), file);
  lean_back(coarse_scene);
  double t0 = cpu_seconds();
  auto coarse = scene::build_simulation(coarse_scene);
  cloth::Cloth& cc = *coarse->cloths()[0];
  cloth::CurvedFaces faces(cc.mesh(), coarse_scene.detail.at(0).levels);
  cloth::Vec3s detail, prev_detail, before;
  faces.evaluate(cc.state().x, prev_detail);
  for (int f = 0; f < frames; ++f) {
    before = cc.state().x;
    coarse->step_frame();
    faces.evaluate(cc.state().x, detail);
    double dc = 0.0, dd = 0.0;
    for (size_t i = 0; i < before.size(); ++i) dc = std::max(dc, (cc.state().x[i] - before[i]).norm());
    for (size_t i = 0; i < detail.size(); ++i) dd = std::max(dd, (detail[i] - prev_detail[i]).norm());
    if (dc > 1e-6) r.worst_move_ratio = std::max(r.worst_move_ratio, dd / dc);
    if (f == frames - 1) r.coarse_speed = dc * 60.0;
    prev_detail = detail;
  }
  r.coarse_cpu = cpu_seconds() - t0;
  r.coarse_vertices = cc.mesh().num_vertices();
  // (b) the full fine simulation.
  scene::Scene fine_scene =
      scene::parse_scene(hybrid_character_scene(coarse_resolution / (1 << levels), 0, frames), file);
  lean_back(fine_scene);
  t0 = cpu_seconds();
  auto fine = scene::build_simulation(fine_scene);
  cloth::Cloth& fc = *fine->cloths()[0];
  const cloth::Vec3s start = fc.state().x;
  for (int f = 0; f < frames; ++f) {
    before = fc.state().x;
    fine->step_frame();
    if (f == frames - 1)
      for (size_t i = 0; i < before.size(); ++i)
        r.fine_speed = std::max(r.fine_speed, (fc.state().x[i] - before[i]).norm() * 60.0);
  }
  r.fine_cpu = cpu_seconds() - t0;
  r.fine_vertices = fc.mesh().num_vertices();
  for (size_t i = 0; i < start.size(); ++i) r.sag = std::max(r.sag, (fc.state().x[i] - start[i]).norm());
  // Point to surface, both ways.
  auto to_surface = [&r](const cloth::Vec3s& points, const cloth::ClothMesh& mesh, const cloth::Vec3s& x,
                         double& sum) {
    for (const cloth::Vec3& p : points) {
      double best = 1e30;
      for (const cloth::Tri& t : mesh.triangles())
        best =
            std::min(best, collision::point_triangle_closest(p, x[t[0]], x[t[1]], x[t[2]]).distance_squared);
      sum += best;
      r.max = std::max(r.max, std::sqrt(best));
    }
  };
  double sum = 0.0;
  to_surface(fc.state().x, *faces.fine_mesh(), detail, sum);
  to_surface(detail, fc.mesh(), fc.state().x, sum);
  r.rms = std::sqrt(sum / static_cast<double>(fc.state().x.size() + detail.size()));
  return r;
}

}  // namespace loom::test
