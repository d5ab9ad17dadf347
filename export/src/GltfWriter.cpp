#include "loom/export/GltfWriter.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

#include "loom/cloth/Error.h"
#include "loom/cloth/OutputFile.h"

namespace loom::exporter {

namespace fs = std::filesystem;

GltfWriter::GltfWriter(std::string gltf_path, std::vector<AnimatedMesh> meshes)
    : gltf_path_(std::move(gltf_path)), meshes_(std::move(meshes)) {
  bin_path_ = fs::path(gltf_path_).replace_extension(".bin").string();
  bin_.open(bin_path_, std::ios::binary | std::ios::trunc);
  if (!bin_) throw Error(bin_path_, "", "cannot write glTF buffer");
  target_accessor_.resize(meshes_.size());
}

int GltfWriter::append_view(const void* data, size_t bytes, int target) {
  View view;
  view.offset = bin_size_;
  view.bytes = bytes;
  view.target = target;
  bin_.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
  if (!bin_) throw Error(bin_path_, "", bin_.write_failure());
  bin_size_ += bytes;  // every element is 4 bytes wide, so every view stays 4-byte aligned
  views_.push_back(view);
  return static_cast<int>(views_.size()) - 1;
}

int GltfWriter::append(const void* data, size_t bytes, int target, Accessor accessor) {
  accessor.view = append_view(data, bytes, target);
  accessors_.push_back(std::move(accessor));
  return static_cast<int>(accessors_.size()) - 1;
}

int GltfWriter::append_vec3(const cloth::Vec3s& v, const cloth::Vec3s* minus) {
  std::vector<float> f(3 * v.size());
  Accessor view;
  view.component = 5126;
  view.type = "VEC3";
  view.count = v.size();
  view.min.assign(3, std::numeric_limits<double>::infinity());
  view.max.assign(3, -std::numeric_limits<double>::infinity());
  for (size_t i = 0; i < v.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      const float value = static_cast<float>(minus ? v[i][k] - (*minus)[i][k] : v[i][k]);
      f[3 * i + k] = value;
      view.min[k] = std::min(view.min[k], double(value));  // bounds of the stored floats, as the spec asks
      view.max[k] = std::max(view.max[k], double(value));
    }
  return append(f.data(), 4 * f.size(), 34962, std::move(view));
}

void GltfWriter::add_frame(double time, const std::vector<const cloth::Vec3s*>& positions) {
  if (positions.size() != meshes_.size()) throw Error(gltf_path_, "", "frame has the wrong number of meshes");
  if (!times_.empty() && !(time > times_.back())) throw Error(gltf_path_, "", "frame times must increase");
  for (size_t m = 0; m < meshes_.size(); ++m)
    if (static_cast<int>(positions[m]->size()) != meshes_[m].vertices)
      throw Error(gltf_path_, meshes_[m].name, "frame has the wrong number of vertices");
  if (times_.empty()) {
    for (size_t m = 0; m < meshes_.size(); ++m) {
      base_.push_back(*positions[m]);
      base_accessor_.push_back(append_vec3(*positions[m], nullptr));
      std::vector<uint32_t> idx;
      idx.reserve(3 * meshes_[m].triangles.size());
      for (const cloth::Tri& t : meshes_[m].triangles)
        for (int k = 0; k < 3; ++k) idx.push_back(static_cast<uint32_t>(t[k]));
      Accessor view;
      view.component = 5125;
      view.type = "SCALAR";
      view.count = idx.size();
      index_accessor_.push_back(append(idx.data(), 4 * idx.size(), 34963, std::move(view)));
    }
  } else {
    for (size_t m = 0; m < meshes_.size(); ++m)
      target_accessor_[m].push_back(append_vec3(*positions[m], &base_[m]));
  }
  times_.push_back(time);
}

void GltfWriter::finish() {
  if (finished_) return;
  finished_ = true;
  using nlohmann::ordered_json;
  const size_t keys = times_.size(), targets = keys ? keys - 1 : 0;
  int times_accessor = -1, weights_accessor = -1;
  if (targets > 0) {
    std::vector<float> t(times_.begin(), times_.end());
    Accessor tv;
    tv.component = 5126;
    tv.type = "SCALAR";
    tv.count = keys;
    tv.min = {double(t.front())};
    tv.max = {double(t.back())};
    times_accessor = append(t.data(), 4 * t.size(), 0, std::move(tv));
    // Key k holds weight 1 on target k-1 (key 0 is the base mesh): element k*targets + k-1 of the
    // keys x targets weights, an increasing sequence, so it is the sparse index list as glTF asks.
    if (keys * targets > std::numeric_limits<uint32_t>::max())
      throw Error(gltf_path_, "", "too many frames for the 32-bit indices of the animation weights");
    std::vector<uint32_t> idx(targets);
    for (size_t k = 1; k < keys; ++k) idx[k - 1] = static_cast<uint32_t>(k * targets + (k - 1));
    const std::vector<float> ones(targets, 1.0f);
    Accessor wv;
    wv.component = 5126;
    wv.type = "SCALAR";
    wv.count = keys * targets;
    wv.sparse_count = targets;
    wv.sparse_indices = append_view(idx.data(), 4 * idx.size(), 0);
    wv.sparse_values = append_view(ones.data(), 4 * ones.size(), 0);
    accessors_.push_back(std::move(wv));
    weights_accessor = static_cast<int>(accessors_.size()) - 1;
  }
  bin_.close();
  if (!bin_) throw Error(bin_path_, "", bin_.write_failure());

  ordered_json j;
  j["asset"] = {{"version", "2.0"}, {"generator", "loom (cloth simulation)"}};
  j["scene"] = 0;
  ordered_json nodes = ordered_json::array(), meshes = ordered_json::array();
  for (size_t m = 0; m < meshes_.size() && !base_.empty(); ++m) {
    nodes.push_back({{"name", meshes_[m].name}, {"mesh", m}});
    ordered_json prim = {{"attributes", {{"POSITION", base_accessor_[m]}}},
                         {"indices", index_accessor_[m]},
                         {"material", 0},
                         {"mode", 4}};
    ordered_json mesh = {{"name", meshes_[m].name}};
    if (targets > 0) {
      ordered_json tg = ordered_json::array(), names = ordered_json::array();
      for (size_t k = 0; k < targets; ++k) {
        tg.push_back({{"POSITION", target_accessor_[m][k]}});
        char name[32];
        std::snprintf(name, sizeof name, "frame_%05zu", k + 1);
        names.push_back(name);
      }
      prim["targets"] = tg;
      mesh["weights"] = std::vector<float>(targets, 0.0f);
      mesh["extras"] = {{"targetNames", names}};
    }
    mesh["primitives"] = ordered_json::array({prim});
    meshes.push_back(mesh);
  }
  ordered_json node_ids = ordered_json::array();
  for (size_t i = 0; i < nodes.size(); ++i) node_ids.push_back(i);
  j["scenes"] = ordered_json::array({{{"name", "loom"}, {"nodes", node_ids}}});
  j["nodes"] = nodes;
  j["meshes"] = meshes;
  j["materials"] = ordered_json::array(
      {{{"name", "cloth"},
        {"doubleSided", true},
        {"pbrMetallicRoughness",
         {{"baseColorFactor", {0.8, 0.3, 0.25, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.9}}}}});
  if (targets > 0) {
    ordered_json channels = ordered_json::array(), samplers = ordered_json::array();
    for (size_t m = 0; m < meshes_.size(); ++m) {
      samplers.push_back(
          {{"input", times_accessor}, {"output", weights_accessor}, {"interpolation", "LINEAR"}});
      channels.push_back({{"sampler", m}, {"target", {{"node", m}, {"path", "weights"}}}});
    }
    j["animations"] =
        ordered_json::array({{{"name", "simulation"}, {"channels", channels}, {"samplers", samplers}}});
  }
  j["buffers"] =
      ordered_json::array({{{"uri", fs::path(bin_path_).filename().string()}, {"byteLength", bin_size_}}});
  ordered_json views = ordered_json::array(), accessors = ordered_json::array();
  for (const View& v : views_) {
    ordered_json bv = {{"buffer", 0}, {"byteOffset", v.offset}, {"byteLength", v.bytes}};
    if (v.target) bv["target"] = v.target;
    views.push_back(bv);
  }
  for (const Accessor& v : accessors_) {
    ordered_json a = ordered_json::object();
    if (v.view >= 0) a["bufferView"] = v.view;
    a["componentType"] = v.component;
    a["count"] = v.count;
    a["type"] = v.type;
    if (!v.min.empty()) {
      a["min"] = v.min;
      a["max"] = v.max;
    }
    if (v.sparse_count > 0)
      a["sparse"] = {{"count", v.sparse_count},
                     {"indices", {{"bufferView", v.sparse_indices}, {"componentType", 5125}}},
                     {"values", {{"bufferView", v.sparse_values}}}};
    accessors.push_back(a);
  }
  j["bufferViews"] = views;
  j["accessors"] = accessors;

  const std::string tmp = gltf_path_ + ".tmp";
  write_file_atomically(gltf_path_, tmp, j.dump() + "\n");
}

}  // namespace loom::exporter
