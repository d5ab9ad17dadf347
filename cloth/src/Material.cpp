#include "loom/cloth/Material.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"

namespace loom::cloth {

void Material::validate(const std::string& file, const std::string& where) const {
  auto show = [](double v) {  // 9 significant digits: 0.0001, 1e-09, 2
    char s[32];
    std::snprintf(s, sizeof s, "%.9g", v);
    return std::string(s);
  };
  auto check = [&](const char* field, double value, double min, bool strict) {
    if (!std::isfinite(value)) throw Error(file, where + "." + field, "must be a finite number");
    if (strict ? !(value > min) : !(value >= min))
      throw Error(file, where + "." + field,
                  "must be " + std::string(strict ? "> " : ">= ") + show(min) + " (got " + show(value) + ")");
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
  p["white_dots_tablecloth"] =
      measured("white_dots_tablecloth", 0.128, 2002.08618, 2027.48559, 19.189022,
               {51.713814e-6, 36.506981e-6, 66.360748e-6, 52.729267e-6, 15.221714e-6},
               {31.282822e-6, 22.910311e-6, 26.350384e-6, 30.637762e-6, 16.726685e-6});
  // ivory-rib-knit: underwear, 95% cotton 5% spandex (Wang et al. 2011).
  p["ivory_rib_knit"] = measured("ivory_rib_knit", 0.276, 42.871021, 65.166023, 83.175644,
                                 {46.237591e-6, 63.086697e-6, 83.192772e-6, 97.574425e-6, 80.726685e-6},
                                 {32.243889e-6, 37.341282e-6, 38.817448e-6, 39.812527e-6, 30.437820e-6});
  // pink-ribbon-brown: blanket, 100% polyester (Wang et al. 2011).
  p["pink_ribbon_brown"] =
      measured("pink_ribbon_brown", 0.228, 151.503906, 244.830673, 30.250183,
               {117.070122e-6, 202.682922e-6, 298.615936e-6, 244.588867e-6, 238.437820e-6},
               {59.774277e-6, 59.260632e-6, 64.199661e-6, 55.017326e-6, 59.221714e-6});
  // navy-sparkle-sweat: sweater, 96% polyester 4% spandex (Wang et al. 2011).
  p["navy_sparkle_sweat"] = measured("navy_sparkle_sweat", 0.224, 12.486332, 3.272434, 17.616289,
                                     {59.469658e-6, 37.500004e-6, 35.787308e-6, 35.737106e-6, 21.033506e-6},
                                     {45.625023e-6, 39.520981e-6, 30.734119e-6, 23.301662e-6, 13.033506e-6});
  // camel-ponte-roma: jacket, 60% polyester 40% rayon (Wang et al. 2011).
  p["camel_ponte_roma"] = measured("camel_ponte_roma", 0.284, 31.146198, 44.028667, 31.896357,
                                   {36.348366e-6, 49.585537e-6, 45.744080e-6, 47.413387e-6, 20.726685e-6},
                                   {37.157593e-6, 34.107452e-6, 33.229435e-6, 34.685535e-6, 10.439938e-6});
  // white-swim-solid: swimsuit, 87% nylon 13% spandex (Wang et al. 2011).
  p["white_swim_solid"] = measured("white_swim_solid", 0.204, 47.971176, 104.615456, 60.773663,
                                   {60.237942e-6, 56.357208e-6, 69.698593e-6, 55.305969e-6, 34.705532e-6},
                                   {51.018833e-6, 50.741455e-6, 50.570576e-6, 50.006001e-6, 24.556618e-6});
  // tango-red-jet-set: jacket, 100% polyester (Wang et al. 2011).
  p["tango_red_jet_set"] = measured("tango_red_jet_set", 0.113, 43.067627, 171.424835, 14.314700,
                                    {14.293814e-6, 8.949391e-6, 30.011126e-6, 36.081490e-6, 18.363136e-6},
                                    {20.345654e-6, 22.696880e-6, 15.698071e-6, 13.466827e-6, 7.556618e-6});
  // denim_kes: denim from KES-F measurements, "Regenerated Cellulose-Based Denim Fabric for Tropical
  // Regions", Journal of Textiles 2016, Table 5 (six fabrics; mid-range values). B = 0.144-0.227 gf·cm²/cm ->
  // 18 µN·m (1 gf·cm²/cm = 98.1 µN·m); G = 1.50-3.40 gf/(cm·deg) -> 137 N/m (1 gf/(cm·deg) = 56.2 N/m per
  // radian); stretch: secant modulus at EMT (strain at 500 gf/cm = 490 N/m), EMT 4.70-5.74% -> 490/0.0522 =
  // 9,390 N/m (KES tensile curves are stiffening, so small-strain stiffness is lower); thickness 0.80-1.19 mm
  // -> 1.0 mm. The table's weight column (94-109 mg/cm²) is implausible for denim; the density is the nominal
  // 11 oz/yd² (0.373 kg/m²), an assumption of ours, not a measurement.
  {
    Material m;
    m.name = "denim_kes";
    m.stretch_weft = m.stretch_warp = 490.0 / 0.0522;
    m.shear = 137.0;
    m.bend_weft = m.bend_warp = 18e-6;
    m.areal_density = 0.373;
    m.thickness = 0.001;
    m.friction = 0.3;
    p["denim_kes"] = m;
  }
  // "cotton": the cotton-blend woven of the list above (royal_target), the benchmark scenes' default.
  p["cotton"] = p["royal_target"];
  p["cotton"].name = "cotton";
  return p;
}

}  // namespace

Material from_clo_style(const CloStyleParameters& p, const std::string& name) {
  Material m;
  m.name = name;
  m.areal_density = p.weight * 1e-3;
  m.thickness = p.thickness * 1e-3;
  m.stretch_weft = p.stretch_weft;
  m.stretch_warp = p.stretch_warp;
  m.shear = p.shear;
  m.bend_weft = p.bending_weft * 1e-6;
  m.bend_warp = p.bending_warp * 1e-6;
  m.friction = p.friction;
  m.damping = p.internal_damping;
  return m;
}

Material material_preset(const std::string& name) {
  static const std::map<std::string, Material> table = presets();
  auto it = table.find(name);
  if (it == table.end()) {
    std::string known;
    for (const auto& kv : table) known += (known.empty() ? "" : ", ") + kv.first;
    throw Error("", "", "unknown material preset '" + show_value(name) + "' (known: " + known + ")");
  }
  return it->second;
}

std::vector<std::string> material_preset_names() {
  std::vector<std::string> names;
  for (const auto& kv : presets()) names.push_back(kv.first);
  return names;
}

}  // namespace loom::cloth
