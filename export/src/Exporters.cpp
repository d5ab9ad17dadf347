#include "loom/export/Exporters.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <set>

#include "loom/cloth/Error.h"
#include "loom/cloth/OutputFile.h"

namespace loom::exporter {

namespace fs = std::filesystem;

namespace {

bool has(const std::vector<std::string>& v, const char* s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

void write_mesh_obj(const fs::path& path, const cloth::Cloth& c) {
  OutputFile out(path);
  if (!out) throw Error(path.string(), "", "cannot write");
  out << std::setprecision(9) << "o " << c.name() << "\n";
  for (const cloth::Vec3& p : c.state().x) out << "v " << p.x() << ' ' << p.y() << ' ' << p.z() << "\n";
  for (const cloth::Tri& t : c.mesh().triangles())
    out << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << "\n";
  out.close();
  if (!out) throw Error(path.string(), "", out.write_failure());
}

}  // namespace

std::vector<std::string> Exporters::file_names(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  // A cloth whose name is already a valid file name keeps it; the others (sanitised: '_' for every other
  // character) take the next free "<name>_<k>", so no file carries another cloth's name.
  const size_t n = cloths.size();
  std::vector<std::string> names(n), sanitised(n);
  std::set<std::string> used;
  for (size_t i = 0; i < n; ++i) {
    std::string s = cloths[i]->name();
    for (char& ch : s)
      if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' || ch == '_')) ch = '_';
    if (s.empty()) s = "cloth";
    sanitised[i] = s;
    if (s == cloths[i]->name() && used.insert(s).second) names[i] = s;
  }
  std::map<std::string, int> next;  // per sanitised name, the suffix to try next (linear in the cloths)
  for (size_t i = 0; i < n; ++i) {
    if (!names[i].empty()) continue;
    const std::string& s = sanitised[i];
    std::string unique = s;
    int& k = next[s];
    while (used.count(unique)) unique = s + "_" + std::to_string(++k);
    used.insert(unique);
    names[i] = unique;
  }
  return names;
}

Exporters::Exporters(const std::string& out_dir, const std::vector<std::string>& formats,
                     const std::vector<std::unique_ptr<cloth::Cloth>>& cloths, int every) {
  const fs::path out(out_dir);
  // The caller owns the folder: earlier files are its to remove, not ours.
  if (has(formats, "pc2")) {
    make_output_folder((out / "pc2").string());
    const std::vector<std::string> names = file_names(cloths);
    for (size_t i = 0; i < cloths.size(); ++i) {
      const fs::path base = out / "pc2" / names[i];
      pc2_mesh_.push_back(base.string() + ".obj");
      pc2_.push_back(
          std::make_unique<Pc2Writer>(base.string() + ".pc2", cloths[i]->state().size(), 0.0, every));
      files_.push_back(base.string() + ".pc2");
    }
  }
  if (has(formats, "gltf")) {
    std::vector<AnimatedMesh> meshes;
    for (const auto& c : cloths) meshes.push_back({c->name(), c->state().size(), c->mesh().triangles()});
    gltf_ = std::make_unique<GltfWriter>((out / "animation.gltf").string(), std::move(meshes));
    files_.push_back(gltf_->gltf_path());
  }
}

void Exporters::frame(double time, const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  for (size_t i = 0; i < pc2_.size(); ++i) {
    if (pc2_[i]->samples() == 0) write_mesh_obj(pc2_mesh_[i], *cloths[i]);  // the first frame's mesh
    pc2_[i]->add_sample(cloths[i]->state().x);
  }
  if (gltf_) {
    std::vector<const cloth::Vec3s*> x;
    for (const auto& c : cloths) x.push_back(&c->state().x);
    gltf_->add_frame(time, x);
  }
}

void Exporters::finish() {
  for (auto& w : pc2_) w->finish();
  if (gltf_) gltf_->finish();
}

std::vector<std::string> Exporters::files() const { return files_; }

}  // namespace loom::exporter
