#include "loom/render/RenderRun.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "gl/ColliderShapes.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/OutputFile.h"

namespace loom::render {

namespace fs = std::filesystem;

std::vector<RenderMesh> render_meshes(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  static const cloth::Vec3 kColors[] = {
      {0.80, 0.22, 0.18}, {0.20, 0.42, 0.75}, {0.90, 0.68, 0.20}, {0.30, 0.62, 0.35}};
  std::vector<RenderMesh> meshes;
  for (size_t i = 0; i < cloths.size(); ++i) {
    RenderMesh m;
    m.triangles = cloths[i]->mesh().triangles();
    for (const auto& f : cloths[i]->mesh().triangle_frames()) m.corner_uv.push_back(f.rest_uv);
    m.color = kColors[i % 4];
    meshes.push_back(std::move(m));
  }
  return meshes;
}

void Recording::add(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  frames_.emplace_back();
  for (const auto& c : cloths) frames_.back().push_back(c->state().x);
  poses_.emplace_back();
  if (colliders_)
    for (const collision::Collider& c : *colliders_) poses_.back().push_back(c.curr);
}

collision::ColliderSet Recording::colliders(int f) const {
  collision::ColliderSet set;
  if (!colliders_) return set;
  set = *colliders_;
  for (size_t k = 0; k < set.size() && k < poses_[f].size(); ++k) set[k].curr = poses_[f][k];
  set.resize(std::min(set.size(), poses_[f].size()));
  return set;
}

Bounds Recording::bounds() const {
  Bounds b;
  for (const auto& f : frames_)
    for (const auto& x : f)
      for (const cloth::Vec3& p : x) b.add(p);
  for (int f = 0; f < frames(); ++f) gl::add_collider_bounds(b, colliders(f));
  return b;
}

Bounds Recording::action_bounds(int f) const {
  Bounds cloth;
  for (const auto& x : frames_[f])
    for (const cloth::Vec3& p : x) cloth.add(p);
  if (cloth.empty()) return cloth;
  const cloth::Vec3 reach = 0.5 * (cloth.hi - cloth.lo) + cloth::Vec3::Constant(0.05);
  Bounds b = cloth;
  for (const collision::Collider& c : colliders(f)) {
    Bounds one;
    gl::add_collider_bounds(one, collision::ColliderSet{c});
    if (one.empty()) continue;
    const bool near = (one.lo.array() <= (cloth.hi + reach).array()).all() &&
                      (one.hi.array() >= (cloth.lo - reach).array()).all();
    if (near) {
      b.add(one.lo);
      b.add(one.hi);
    }
  }
  return b;
}

namespace {

// Camera for a recording: the direction and field of view of auto_camera, at the largest distance any
// frame's action needs (no zoom pumping), looking at each frame's action centre smoothed over about
// 0.3 s (a critically damped follow would lag more; an unsmoothed one shakes with the cloth).
std::vector<cloth::Vec3> tracked_targets(const Recording& rec, double fps, double aspect, Bounds& widest) {
  std::vector<cloth::Vec3> targets;
  double distance = 0.0;
  const double alpha = 1.0 - std::exp(-1.0 / (0.3 * std::max(fps, 1.0)));
  for (int f = 0; f < rec.frames(); ++f) {
    const Bounds b = rec.action_bounds(f);
    if (b.empty()) {
      targets.push_back(targets.empty() ? cloth::Vec3::Zero() : targets.back());
      continue;
    }
    const cloth::Vec3 centre = 0.5 * (b.lo + b.hi);
    targets.push_back(targets.empty() ? centre : targets.back() + alpha * (centre - targets.back()));
    const Camera c = auto_camera(b, aspect);
    const double d = (c.eye - c.target).norm();
    if (d > distance) {
      distance = d;
      widest = b;
    }
  }
  return targets;
}

}  // namespace

double render_memory_bytes(const RenderSettings& settings, double frames, double vertices, double colliders) {
  const double s = settings.supersample;
  const double pixels = double(settings.width) * double(settings.height);
  return frames * (24.0 * vertices + 128.0 * colliders) + pixels * (8.0 * s * s + kBytesPerPixel);
}

RenderReport render_recording(const std::string& out_dir, const Recording& rec,
                              const RenderSettings& settings, double fps,
                              const volatile std::sig_atomic_t* stop) {
  const fs::path out(out_dir), dir = out / "render";
  // The caller owns the folder and removes its earlier files (RenderRun.h); the folder is made and the PNGs
  // written from the output folder's descriptor (OutputFile.h), never through a link.
  make_output_folder(dir.string());

  const auto start = std::chrono::steady_clock::now();
  Renderer r(settings, rec.meshes());
  const collision::ColliderSet first = rec.frames() ? rec.colliders(0) : collision::ColliderSet{};
  Bounds widest;
  const std::vector<cloth::Vec3> targets =
      tracked_targets(rec, fps, double(settings.width) / settings.height, widest);
  if (widest.empty()) widest = rec.bounds();
  r.frame(widest, &first);
  RenderReport rep;
  for (int f = 0; f < rec.frames(); ++f) {
    if (stop && *stop) {
      rep.stopped = true;
      break;
    }
    r.look_at(targets[f]);
    std::vector<const cloth::Vec3s*> x;
    for (const auto& p : rec.positions()[f]) x.push_back(&p);
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.png", f);
    const collision::ColliderSet colliders = rec.colliders(f);
    write_png((dir / name).string(), r.render(x, &colliders));
    ++rep.frames;
  }
  rep.ms_per_frame =
      rep.frames
          ? std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() /
                rep.frames
          : 0.0;
  return rep;
}

}  // namespace loom::render
