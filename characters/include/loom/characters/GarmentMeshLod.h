#pragma once
// GarmentMeshLod: coarse-mesh level of detail for a skinned garment. The garment is given as a coarse mesh
// (with its skin and weight maps); the surface that is shown is always the fine mesh of the curved-face
// hybrid (cloth/CurvedFaces.h: PN-triangle patches, `levels` 1:4 subdivisions of every coarse triangle).
//   near (distance < switch_distance): the fine mesh itself is simulated (a GarmentInstance on the fine
//     mesh) and shown;
//   far: the coarse mesh is simulated and the fine surface shown is its curved faces, evaluated from the
//     coarse render positions each frame.
// The fine garment's bind positions are the curved surface of the coarse bind positions; each fine vertex
// takes the coarse data of its coarse triangle by barycentric weights: the skin (the corners' influences
// summed by weight, the four largest kept and renormalised), the max distances and backstop distances.
//
// Switching (set_distance, applied at the end of the next step(); with a hysteresis band so a distance that
// hovers around the threshold does not flip every frame): the inactive instance is put on the current pose
// (set_pose, reset) and given the active one's state, fine <- curved faces of the coarse positions
// (velocities by barycentric interpolation), coarse <- the fine vertices on the coarse corners. Only the
// active instance is posed and stepped, so a far garment costs the coarse simulation plus the curved-face
// evaluation. No pop: at the switch frame the shown positions stay those of the representation before, and
// the difference fades out linearly over blend_time (the same blend as the rate LOD, GarmentInstance.h).
#include <memory>
#include <string>
#include <vector>

#include "loom/characters/GarmentInstance.h"
#include "loom/cloth/CurvedFaces.h"

namespace loom::characters {

struct GarmentMeshLodSettings {
  int levels = 1;                // 1:4 subdivisions of each coarse triangle in the fine mesh (1-3)
  double switch_distance = 5.0;  // m, > 0: nearer simulates the fine mesh
  double hysteresis = 0.5;       // m, >= 0: switch to fine below switch - h, to coarse above switch + h
  double blend_time = 0.2;       // s, >= 0: the shown positions fade from the old mesh to the new one
};

class GarmentMeshLod {
 public:
  // `settings` hold the coarse garment's maps (per coarse vertex). Starts with the coarse mesh simulated.
  // Throws loom::Error(source, field, problem) for bad settings ("lod_mesh.levels",
  // "lod_mesh.switch_distance", "lod_mesh.hysteresis", "lod_mesh.blend_time") and everything GarmentInstance
  // refuses.
  GarmentMeshLod(const cloth::Vec3s& coarse_bind, const std::vector<cloth::Tri>& coarse_triangles,
                 const Skin& coarse_skin, const GarmentSettings& settings, const std::vector<Affine>& pose,
                 const GarmentMeshLodSettings& lod = {}, const std::string& source = "garment");

  void set_pose(const std::vector<Affine>& bones);
  // Advances the active garment by frame_dt (s), switches if set_distance asked for it, and updates the
  // shown positions.
  void step(double frame_dt);
  // Camera distance (m, finite, >= 0); throws loom::Error(source, "distance", ...) otherwise.
  void set_distance(double distance);
  // Switches at the end of the next step() regardless of the distance (true: fine simulated).
  void force(bool fine) { want_fine_ = fine; }
  bool fine_active() const { return fine_active_; }
  long switches() const { return switches_; }

  int num_vertices() const { return static_cast<int>(shown_.size()); }  // the fine mesh's
  const std::vector<cloth::Tri>& triangles() const { return curved_.fine_mesh()->triangles(); }
  // The fine positions shown after the last step() (m), and as floats into dst[i * stride + 0..2].
  const cloth::Vec3s& shown() const { return shown_; }
  void write_positions(float* dst, size_t stride) const;

  GarmentInstance& coarse() { return *coarse_; }
  GarmentInstance& fine() { return *fine_; }
  const cloth::CurvedFaces& curved_faces() const { return curved_; }

 private:
  void unblended(cloth::Vec3s& out);  // the active representation's fine positions now
  void switch_to(bool fine);

  std::string source_;
  GarmentMeshLodSettings lod_;
  cloth::CurvedFaces curved_;
  std::unique_ptr<GarmentInstance> coarse_, fine_;
  std::vector<Affine> bones_;
  bool fine_active_ = false, want_fine_ = false;
  long switches_ = 0;
  double clock_ = 0.0;         // s, frame time
  double blend_start_ = -1.0;  // s, clock at the last switch (< 0: none)
  cloth::Vec3s blend_offset_;  // m, shown minus unblended positions at the switch
  cloth::Vec3s shown_, fine_scratch_, coarse_scratch_, coarse_v_;
  std::vector<float> buffer_;  // render positions of the active instance
};

}  // namespace loom::characters
