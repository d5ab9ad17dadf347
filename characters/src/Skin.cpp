#include "loom/characters/Skin.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "loom/cloth/Error.h"
#include "loom/collision/Distance.h"

namespace loom::characters {

namespace {

std::string vertex_field(size_t i) { return "vertices[" + std::to_string(i) + "]"; }

}  // namespace

Skin::Skin(std::vector<std::string> bone_names, std::vector<Affine> inverse_bind,
           const std::vector<std::vector<BoneInfluence>>& influences, const std::string& source)
    : bone_names_(std::move(bone_names)), inverse_bind_(std::move(inverse_bind)) {
  if (inverse_bind_.size() != bone_names_.size())
    throw Error(source, "bones",
                std::to_string(bone_names_.size()) + " names but " + std::to_string(inverse_bind_.size()) +
                    " inverse bind matrices");
  for (size_t b = 0; b < inverse_bind_.size(); ++b)
    if (!inverse_bind_[b].matrix().allFinite())
      throw Error(source, "bones[" + std::to_string(b) + "].inverse_bind", "is not finite");
  const int nb = num_bones();
  bones_.resize(influences.size());
  weights_.resize(influences.size());
  for (size_t i = 0; i < influences.size(); ++i) {
    const auto& inf = influences[i];
    if (inf.size() > static_cast<size_t>(kMaxInfluences))
      throw Error(
          source, vertex_field(i),
          std::to_string(inf.size()) + " bone influences (at most " + std::to_string(kMaxInfluences) + ")");
    bones_[i].fill(-1);
    weights_[i].fill(0.0);
    double sum = 0.0;
    for (size_t k = 0; k < inf.size(); ++k) {
      if (inf[k].bone < 0 || inf[k].bone >= nb)
        throw Error(source, vertex_field(i) + ".bones[" + std::to_string(k) + "]",
                    "bone " + std::to_string(inf[k].bone) + " does not exist (the skin has " +
                        std::to_string(nb) + " bones)");
      if (!(inf[k].weight >= 0.0 && inf[k].weight <= 1.0))
        throw Error(source, vertex_field(i) + ".weights[" + std::to_string(k) + "]",
                    "weight " + std::to_string(inf[k].weight) + " is not in [0, 1]");
      bones_[i][k] = inf[k].bone;
      weights_[i][k] = inf[k].weight;
      sum += inf[k].weight;
    }
    if (!(std::abs(sum - 1.0) <= kWeightTolerance))
      throw Error(source, vertex_field(i) + ".weights",
                  "the weights sum to " + std::to_string(sum) + " (must be 1 within 1e-6)");
  }
}

Skin Skin::automatic(const cloth::Vec3s& positions, std::vector<std::string> bone_names,
                     const std::vector<Affine>& bind_global, const std::vector<int>& parent, int influences,
                     const std::string& source) {
  const size_t nb = bone_names.size();
  if (bind_global.size() != nb || parent.size() != nb)
    throw Error(source, "bones", "names, bind transforms and parents differ in number");
  if (nb == 0) throw Error(source, "bones", "automatic weights need at least one bone");
  if (influences < 1 || influences > kMaxInfluences)
    throw Error(source, "influences", std::to_string(influences) + " is not in [1, 4]");
  for (size_t b = 0; b < nb; ++b) {
    if (!bind_global[b].matrix().allFinite())
      throw Error(source, "bones[" + std::to_string(b) + "].bind", "is not finite");
    if (parent[b] < -1 || parent[b] >= static_cast<int>(b))
      throw Error(source, "bones[" + std::to_string(b) + "].parent", "must be -1 or an earlier bone");
  }
  // Segment of each bone: its joint to the mean of its children's joints.
  std::vector<cloth::Vec3> head(nb), tail(nb, cloth::Vec3::Zero());
  std::vector<int> children(nb, 0);
  for (size_t b = 0; b < nb; ++b) head[b] = bind_global[b].translation();
  for (size_t b = 0; b < nb; ++b)
    if (parent[b] >= 0) {
      tail[parent[b]] += head[b];
      ++children[parent[b]];
    }
  for (size_t b = 0; b < nb; ++b) tail[b] = children[b] > 0 ? cloth::Vec3(tail[b] / children[b]) : head[b];

  constexpr double kEps = 1e-3;  // m
  const int keep = std::min<int>(influences, static_cast<int>(nb));
  std::vector<std::vector<BoneInfluence>> inf(positions.size());
  std::vector<std::pair<double, int>> dist(nb);
  for (size_t i = 0; i < positions.size(); ++i) {
    if (!positions[i].allFinite())
      throw Error(source, "positions[" + std::to_string(i) + "]", "is not finite");
    for (size_t b = 0; b < nb; ++b)
      dist[b] = {collision::point_segment_distance(positions[i], head[b], tail[b]), static_cast<int>(b)};
    std::partial_sort(dist.begin(), dist.begin() + keep, dist.end());
    double sum = 0.0;
    for (int k = 0; k < keep; ++k) {
      const double w = 1.0 / std::pow(dist[k].first + kEps, 4);
      inf[i].push_back({dist[k].second, w});
      sum += w;
    }
    for (auto& x : inf[i]) x.weight /= sum;
  }
  std::vector<Affine> inverse_bind(nb);
  for (size_t b = 0; b < nb; ++b) inverse_bind[b] = bind_global[b].inverse();
  return Skin(std::move(bone_names), std::move(inverse_bind), inf, source);
}

int Skin::find(const std::string& name) const {
  for (int b = 0; b < num_bones(); ++b)
    if (bone_names_[b] == name) return b;
  return -1;
}

void Skin::skinning_matrices(const std::vector<Affine>& pose, std::vector<Affine>& out,
                             const std::string& source) const {
  if (pose.size() != inverse_bind_.size())
    throw Error(source, "pose",
                std::to_string(pose.size()) + " bone transforms for a skin of " +
                    std::to_string(inverse_bind_.size()) + " bones");
  out.resize(pose.size());
  for (size_t b = 0; b < pose.size(); ++b) {
    if (!pose[b].matrix().allFinite())
      throw Error(source, "pose[" + std::to_string(b) + "]", "is not finite");
    out[b] = pose[b] * inverse_bind_[b];
  }
}

void Skin::apply(const std::vector<Affine>& matrices, const cloth::Vec3s& rest, cloth::Vec3s& out) const {
  const int n = num_vertices();
  out.resize(n);
  for (int i = 0; i < n; ++i) {
    cloth::Vec3 x = cloth::Vec3::Zero();
    for (int k = 0; k < kMaxInfluences; ++k)
      if (bones_[i][k] >= 0) x += weights_[i][k] * (matrices[bones_[i][k]] * rest[i]);
    out[i] = x;
  }
}

}  // namespace loom::characters
