#include "loom/bullet/BodyCrossings.h"

#include <utility>

#include "loom/collision/Ccd.h"

namespace loom::bullet {

bool centre_meets_cloth(const cloth::ClothMesh& mesh, const cloth::Vec3s& x0, const cloth::Vec3s& x1,
                        const cloth::Vec3& c0, const cloth::Vec3& c1) {
  const cloth::Vec3 plo = c0.cwiseMin(c1), phi = c0.cwiseMax(c1);
  for (const cloth::Tri& t : mesh.triangles()) {
    cloth::Vec3 lo = x0[t[0]], hi = x0[t[0]];
    for (int k = 0; k < 3; ++k) {
      lo = lo.cwiseMin(x0[t[k]]).cwiseMin(x1[t[k]]);
      hi = hi.cwiseMax(x0[t[k]]).cwiseMax(x1[t[k]]);
    }
    if ((lo.array() > phi.array()).any() || (hi.array() < plo.array()).any()) continue;
    if (collision::vertex_face_ccd(c0, x0[t[0]], x0[t[1]], x0[t[2]], c1, x1[t[0]], x1[t[1]], x1[t[2]]).hit)
      return true;
  }
  return false;
}

BodyCrossings::BodyCrossings(std::vector<const cloth::ClothMesh*> meshes, std::vector<cloth::Vec3s> x,
                             std::vector<cloth::Vec3> centres, std::vector<char> modes)
    : meshes_(std::move(meshes)), x_(std::move(x)), centre_(std::move(centres)), mode_(std::move(modes)) {
  mode_.resize(centre_.size(), kAlways);
  crossed_.assign(centre_.size(), 0);
  met_.assign(centre_.size(), 0);
}

int BodyCrossings::update(std::vector<cloth::Vec3s> x, std::vector<cloth::Vec3> centres) {
  int through = 0;
  for (size_t b = 0; b < centre_.size() && b < centres.size(); ++b) {
    met_[b] = 0;
    if (mode_[b] == kSkip) continue;
    for (size_t k = 0; k < meshes_.size() && !met_[b]; ++k)
      met_[b] = centre_meets_cloth(*meshes_[k], x_[k], x[k], centre_[b], centres[b]) ? 1 : 0;
    if (met_[b]) ++through, crossed_[b] = 1;
  }
  x_ = std::move(x);
  centre_ = std::move(centres);
  return through;
}

int BodyCrossings::bodies_through() const {
  int k = 0;
  for (char c : crossed_) k += c;
  return k;
}

}  // namespace loom::bullet
