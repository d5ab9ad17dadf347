#include "loom/cloth/Material.h"

#include <cmath>
#include <map>

#include "loom/cloth/Error.h"

namespace loom::cloth {

void Material::validate(const std::string& file, const std::string& where) const {
  auto check = [&](const char* field, double value, double min, bool strict) {
    if (!std::isfinite(value)) throw Error(file, where + "." + field, "must be a finite number");
    if (strict ? !(value > min) : !(value >= min))
      throw Error(file, where + "." + field,
                  "must be " + std::string(strict ? "> " : ">= ") + std::to_string(min) + " (got " + std::to_string(value) + ")");
  };
  check("stretch_weft", stretch_weft, 0.0, true);
  check("stretch_warp", stretch_warp, 0.0, true);
  check("shear", shear, 0.0, false);
  check("bend_weft", bend_weft, 0.0, false);
  check("bend_warp", bend_warp, 0.0, false);
  check("areal_density", areal_density, 0.0, true);
  check("damping", damping, 0.0, false);
  check("friction", friction, 0.0, false);
  check("thickness", thickness, 0.0, false);
}

namespace {

// Wang, Ramamoorthi, O'Brien 2011, "Data-Driven Elastic Models for Cloth", measured materials as shipped in
// ARCSim's materials/*.json. Stretch: the small-strain row of "stretching" (C11 along u = weft, C22 along
// v = warp, C33 = shear), taken as 2D moduli in N/m as stored (ARCSim doubles them internally for its
// strain convention; the doubling is not applied here). Bending: mean of the 5 curvature samples of the
// 0° (weft) and 90° (warp) rows, N·m. Density in kg/m².
Material measured(const char* name, double density, double c11, double c22, double c33,
                  const double (&bend0)[5], const double (&bend90)[5]) {
  Material m;
  m.name = name;
  m.areal_density = density;
  m.stretch_weft = c11;
  m.stretch_warp = c22;
  m.shear = c33;
  double b0 = 0.0, b90 = 0.0;
  for (int k = 0; k < 5; ++k) {
    b0 += bend0[k] / 5.0;
    b90 += bend90[k] / 5.0;
  }
  m.bend_weft = b0;
  m.bend_warp = b90;
  m.damping = 0.0;  // not measured by Wang et al.; scenes choose it
  m.friction = 0.3;
  m.thickness = 0.001;
  return m;
}

std::map<std::string, Material> presets() {
  std::map<std::string, Material> p;
  // royal-target: pants, 65% cotton 35% polyester (Wang et al. 2011).
  p["royal_target"] = measured("royal_target", 0.220, 2016.55456, 2034.97644, 104.759674,
                               {125.409805e-6, 167.284561e-6, 215.412750e-6, 215.090790e-6, 223.861038e-6},
                               {125.409805e-6, 167.284561e-6, 215.412750e-6, 215.090790e-6, 227.861038e-6});
  // 11oz-black-denim: jeans, 99% cotton 1% spandex (Wang et al. 2011).
  p["denim_11oz"] = measured("denim_11oz", 0.324, 205.352005, 1013.88629, 53.387184,
                             {64.196457e-6, 60.286175e-6, 60.943428e-6, 62.433697e-6, 19.824701e-6},
                             {96.951576e-6, 107.848228e-6, 113.060738e-6, 120.569740e-6, 79.781021e-6});
  // gray-interlock: t-shirt knit, 60% cotton 40% polyester (Wang et al. 2011).
  p["gray_interlock"] = measured("gray_interlock", 0.187, 16.593832, 34.477123, 36.860302,
                                 {23.191698e-6, 32.932217e-6, 34.406498e-6, 39.014420e-6, 23.382786e-6},
                                 {14.267624e-6, 7.052906e-6, 14.515154e-6, 24.665127e-6, 19.383726e-6});
  // white-dots-on-blk: tablecloth, 100% polyester (Wang et al. 2011).
  p["white_dots_tablecloth"] = measured("white_dots_tablecloth", 0.128, 2002.08618, 2027.48559, 19.189022,
                                        {51.713814e-6, 36.506981e-6, 66.360748e-6, 52.729267e-6, 15.221714e-6},
                                        {31.282822e-6, 22.910311e-6, 26.350384e-6, 30.637762e-6, 16.726685e-6});
  // "cotton": the cotton-blend woven of the list above (royal_target), the benchmark scenes' default.
  p["cotton"] = p["royal_target"];
  p["cotton"].name = "cotton";
  return p;
}

}  // namespace

Material material_preset(const std::string& name) {
  static const std::map<std::string, Material> table = presets();
  auto it = table.find(name);
  if (it == table.end()) {
    std::string known;
    for (const auto& kv : table) known += (known.empty() ? "" : ", ") + kv.first;
    throw Error("", "", "unknown material preset '" + name + "' (known: " + known + ")");
  }
  return it->second;
}

std::vector<std::string> material_preset_names() {
  std::vector<std::string> names;
  for (const auto& kv : presets()) names.push_back(kv.first);
  return names;
}

}  // namespace loom::cloth
