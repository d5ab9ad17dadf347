#pragma once
// Material: a fabric in physical units only (docs/architecture.md; docs/references.md, "Fabric measurement").
// Per-element stiffnesses are derived from it by resolution-independent mappings (SpringSet.h), never stored
// here.
#include <string>
#include <vector>

namespace loom::cloth {

struct Material {
  std::string name = "custom";
  double stretch_weft = 2000.0;  // N/m, 2D Young's modulus along the weft (material u axis)
  double stretch_warp = 2000.0;  // N/m, 2D Young's modulus along the warp (material v axis)
  double shear = 100.0;          // N/m, 2D in-plane shear modulus
  double bend_weft = 1.0e-5;     // N·m, bending rigidity for curvature along the weft
  double bend_warp = 1.0e-5;     // N·m, bending rigidity for curvature along the warp
  double areal_density = 0.2;    // kg/m²
  double damping = 0.0;          // s, stiffness-proportional internal damping: c = damping * k per element
  double friction = 0.3;         // 1, Coulomb coefficient (used by collision)
  double thickness = 0.001;      // m, collision offset (never used to derive bending)

  // Throws loom::Error("", where + ".<field>", problem) if a value is non-finite or out of range.
  void validate(const std::string& file, const std::string& where) const;
};

// A Clo3D / Marvelous Designer-style parameter set (the fields those tools expose, docs/references.md,
// "Fabric measurement"), in stated physical units. CLO's slider values (0-99) have no documented units, so
// they are not accepted raw: convert them with the fabric's physical measurements (CLO's Fabric Kit reports
// these quantities) or calibrate with `loom fabric-test cantilever` / `tensile`.
struct CloStyleParameters {
  double weight = 200.0;          // g/m²            -> areal_density = weight / 1000 kg/m²
  double thickness = 1.0;         // mm              -> thickness / 1000 m (collision offset only)
  double stretch_weft = 2000.0;   // N/m             -> stretch_weft
  double stretch_warp = 2000.0;   // N/m             -> stretch_warp
  double shear = 100.0;           // N/m             -> shear
  double bending_weft = 10.0;     // µN·m            -> bend_weft = 1e-6 bending_weft N·m
  double bending_warp = 10.0;     // µN·m            -> bend_warp
  double friction = 0.3;          // 1               -> friction
  double internal_damping = 0.0;  // s               -> damping (stiffness-proportional, docs/references.md)
};
Material from_clo_style(const CloStyleParameters& p, const std::string& name = "clo_style");

// Measured presets. Each one cites its source in Material.cpp. Throws loom::Error for an unknown name.
Material material_preset(const std::string& name);
std::vector<std::string> material_preset_names();

}  // namespace loom::cloth
