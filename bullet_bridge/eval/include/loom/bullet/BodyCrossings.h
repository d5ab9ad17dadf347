#pragma once
// Bodies through a cloth, for the evaluation of Bullet worlds (the bridge's scene tests, `loom bench
// realtime`). A body is through when its centre meets the cloth's surface: between two calls the centre moves
// linearly from c0 to c1 and each triangle's vertices linearly from their old to their new positions, and a
// vertex-face continuous test (collision::vertex_face_ccd, conservative) of the centre against any triangle
// hits (centre_meets_cloth). A body that goes round the cloth's border (under a free hem that swings out with
// it) never meets the surface and is not counted. Bullet-free: it takes positions, so the same count runs on
// Loom's cloth and on a Bullet soft-body twin.
#include <vector>

#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Types.h"

namespace loom::bullet {

// True when a point moving linearly c0 -> c1 meets a triangle of `mesh` whose vertices move linearly
// x0 -> x1 over the same interval (a swept-box cull, then collision::vertex_face_ccd).
bool centre_meets_cloth(const cloth::ClothMesh& mesh, const cloth::Vec3s& x0, const cloth::Vec3s& x1,
                        const cloth::Vec3& c0, const cloth::Vec3& c1);

class BodyCrossings {
 public:
  // kSkip: a body the cloth is attached to (its centre sits by the cloth): not checked.
  enum Mode : char { kAlways = 0, kSkip = 2 };
  // meshes[k] with positions x[k] now (each outlives this object); body centres now (m).
  BodyCrossings(std::vector<const cloth::ClothMesh*> meshes, std::vector<cloth::Vec3s> x,
                std::vector<cloth::Vec3> centres, std::vector<char> modes = {});
  // Checks every body against the motion since the last call (call once per frame); returns how many met
  // the cloth's surface in it.
  int update(std::vector<cloth::Vec3s> x, std::vector<cloth::Vec3> centres);
  // Bodies that met the cloth's surface at least once so far.
  int bodies_through() const;
  bool crossed(size_t b) const { return crossed_[b] != 0; }
  // Whether body b met the surface in the last update.
  bool met_last(size_t b) const { return met_[b] != 0; }

 private:
  std::vector<const cloth::ClothMesh*> meshes_;
  std::vector<cloth::Vec3s> x_;      // m, cloth positions at the last call
  std::vector<cloth::Vec3> centre_;  // m, body centres at the last call
  std::vector<char> mode_, crossed_, met_;
};

}  // namespace loom::bullet
