#include "loom/characters/GarmentMeshLod.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Error.h"

namespace loom::characters {

namespace {

using cloth::Vec3;
using cloth::Vec3s;

const GarmentMeshLodSettings& checked(const GarmentMeshLodSettings& lod, const std::string& source) {
  if (lod.levels < 1 || lod.levels > 3)
    throw Error(source, "lod_mesh.levels", std::to_string(lod.levels) + " is not in [1, 3]");
  if (!(lod.switch_distance > 0.0) || !std::isfinite(lod.switch_distance))
    throw Error(source, "lod_mesh.switch_distance", "must be finite and > 0 m");
  if (!(lod.hysteresis >= 0.0) || !std::isfinite(lod.hysteresis))
    throw Error(source, "lod_mesh.hysteresis", "must be finite and >= 0 m");
  if (!(lod.blend_time >= 0.0) || !std::isfinite(lod.blend_time))
    throw Error(source, "lod_mesh.blend_time", "must be finite and >= 0 s");
  return lod;
}

cloth::CurvedFaces make_curved(const Vec3s& bind, const std::vector<cloth::Tri>& tris, int levels,
                               const std::string& source) {
  const auto mesh = cloth::ClothMesh::from_triangles(bind, tris, {}, source);
  return cloth::CurvedFaces(*mesh, levels, source, "lod_mesh");
}

// Σ_k w_k a[corner_k] over the corners with w_k > 0 (so an ∞ max distance with weight 0 stays out).
double blend(const std::vector<double>& a, const cloth::Tri& t, const Vec3& w) {
  double s = 0.0;
  for (int k = 0; k < 3; ++k)
    if (w[k] > 0.0) s += w[k] * a[t[k]];
  return s;
}

}  // namespace

GarmentMeshLod::GarmentMeshLod(const Vec3s& coarse_bind, const std::vector<cloth::Tri>& coarse_triangles,
                               const Skin& coarse_skin, const GarmentSettings& settings,
                               const std::vector<Affine>& pose, const GarmentMeshLodSettings& lod,
                               const std::string& source)
    : source_(source),
      lod_(checked(lod, source)),
      curved_(make_curved(coarse_bind, coarse_triangles, lod.levels, source)) {
  coarse_ =
      std::make_unique<GarmentInstance>(coarse_bind, coarse_triangles, coarse_skin, settings, pose, source);
  // The fine garment: the curved surface of the coarse bind mesh, its data by barycentric weights.
  const Vec3s& fine_bind = curved_.fine_mesh()->rest_positions();
  const int nf = static_cast<int>(fine_bind.size());
  const std::vector<cloth::Tri>& ct = curved_.coarse_triangles();
  std::vector<std::vector<BoneInfluence>> influences(nf);
  GarmentSettings fine_settings = settings;
  cloth::SkinConstraintSettings& fc = fine_settings.constraints;
  const cloth::SkinConstraintSettings& cc = settings.constraints;
  fc.max_distance.assign(cc.max_distance.empty() ? 0 : nf, 0.0);
  fc.backstop_distance.assign(cc.backstop_distance.empty() ? 0 : nf, 0.0);
  for (int f = 0; f < nf; ++f) {
    const cloth::Tri& t = ct[curved_.sample_triangle(f)];
    const Vec3& w = curved_.sample_weights(f);
    std::map<int, double> sum;  // bone -> weight
    for (int k = 0; k < 3; ++k)
      for (int q = 0; q < Skin::kMaxInfluences; ++q)
        if (coarse_skin.bones(t[k])[q] >= 0)
          sum[coarse_skin.bones(t[k])[q]] += w[k] * coarse_skin.weights(t[k])[q];
    std::vector<BoneInfluence> inf;
    for (const auto& [bone, weight] : sum)
      if (weight > 0.0) inf.push_back({bone, weight});
    std::sort(inf.begin(), inf.end(), [](const BoneInfluence& a, const BoneInfluence& b) {
      return a.weight > b.weight || (a.weight == b.weight && a.bone < b.bone);
    });
    if (inf.size() > Skin::kMaxInfluences) inf.resize(Skin::kMaxInfluences);
    double total = 0.0;
    for (const BoneInfluence& b : inf) total += b.weight;
    for (BoneInfluence& b : inf) b.weight /= total;
    influences[f] = std::move(inf);
    if (!fc.max_distance.empty()) fc.max_distance[f] = blend(cc.max_distance, t, w);
    if (!fc.backstop_distance.empty()) fc.backstop_distance[f] = blend(cc.backstop_distance, t, w);
  }
  const Skin fine_skin(coarse_skin.bone_names(), coarse_skin.inverse_bind(), influences, source + " (fine)");
  fine_ = std::make_unique<GarmentInstance>(fine_bind, curved_.fine_mesh()->triangles(), fine_skin,
                                            fine_settings, pose, source + " (fine)");
  bones_ = pose;
  unblended(shown_);
}

void GarmentMeshLod::set_pose(const std::vector<Affine>& bones) {
  (fine_active_ ? fine_ : coarse_)->set_pose(bones);
  bones_ = bones;
}

void GarmentMeshLod::set_distance(double distance) {
  if (!(distance >= 0.0) || !std::isfinite(distance))
    throw Error(source_, "distance", std::to_string(distance) + " must be finite and >= 0 m");
  if (fine_active_)
    want_fine_ = distance <= lod_.switch_distance + lod_.hysteresis;
  else
    want_fine_ = distance < lod_.switch_distance - lod_.hysteresis;
}

void GarmentMeshLod::unblended(Vec3s& out) {
  GarmentInstance& g = fine_active_ ? *fine_ : *coarse_;
  buffer_.resize(3 * static_cast<size_t>(g.num_vertices()));
  g.write_positions(buffer_.data(), 3);
  Vec3s& x = fine_active_ ? out : coarse_scratch_;
  x.resize(g.num_vertices());
  for (int i = 0; i < g.num_vertices(); ++i)
    x[i] = Vec3(buffer_[3 * i], buffer_[3 * i + 1], buffer_[3 * i + 2]);
  if (!fine_active_) curved_.evaluate(coarse_scratch_, out);
}

void GarmentMeshLod::switch_to(bool fine) {
  if (fine) {
    const Vec3s& xc = coarse_->positions();
    const Vec3s& vc = coarse_->velocities();
    Vec3s x, v(fine_->num_vertices(), Vec3::Zero());
    curved_.evaluate(xc, x);
    for (int f = 0; f < fine_->num_vertices(); ++f) {
      const cloth::Tri& t = curved_.coarse_triangles()[curved_.sample_triangle(f)];
      const Vec3& w = curved_.sample_weights(f);
      v[f] = w[0] * vc[t[0]] + w[1] * vc[t[1]] + w[2] * vc[t[2]];
    }
    fine_->set_pose(bones_);
    fine_->reset();
    fine_->set_state(x, v);
  } else {
    const Vec3s& xf = fine_->positions();
    const Vec3s& vf = fine_->velocities();
    Vec3s x(coarse_->num_vertices()), v(coarse_->num_vertices());
    for (int i = 0; i < coarse_->num_vertices(); ++i) {
      x[i] = xf[curved_.fine_vertex_of(i)];
      v[i] = vf[curved_.fine_vertex_of(i)];
    }
    coarse_->set_pose(bones_);
    coarse_->reset();
    coarse_->set_state(x, v);
  }
  fine_active_ = fine;
  ++switches_;
}

void GarmentMeshLod::step(double frame_dt) {
  (fine_active_ ? fine_ : coarse_)->step(frame_dt);
  clock_ += frame_dt;
  const double bt = lod_.blend_time;
  auto fade = [&] {                                     // weight of the offset now
    if (blend_start_ < 0.0 || !(bt > 0.0)) return 0.0;  // blend_time 0: the switch shows at once
    return std::max(0.0, 1.0 - (clock_ - blend_start_) / bt);
  };
  unblended(fine_scratch_);
  if (want_fine_ != fine_active_) {
    // What would be shown now without the switch; after it, the new mesh plus the difference.
    const double b = fade();
    for (size_t i = 0; i < fine_scratch_.size(); ++i)
      if (b > 0.0) fine_scratch_[i] += b * blend_offset_[i];
    const Vec3s before = fine_scratch_;
    switch_to(want_fine_);
    unblended(fine_scratch_);
    blend_offset_.resize(before.size());
    for (size_t i = 0; i < before.size(); ++i) blend_offset_[i] = before[i] - fine_scratch_[i];
    blend_start_ = clock_;
  }
  const double b = fade();
  shown_ = fine_scratch_;
  if (b > 0.0)
    for (size_t i = 0; i < shown_.size(); ++i) shown_[i] += b * blend_offset_[i];
}

void GarmentMeshLod::write_positions(float* dst, size_t stride) const {
  for (size_t i = 0; i < shown_.size(); ++i) {
    float* d = dst + i * stride;
    d[0] = static_cast<float>(shown_[i].x());
    d[1] = static_cast<float>(shown_[i].y());
    d[2] = static_cast<float>(shown_[i].z());
  }
}

}  // namespace loom::characters
