#include "loom/cloth/PressureTerm.h"

#include <cmath>
#include <cstdio>

#include "TriangleGather.h"
#include "loom/cloth/Error.h"

namespace loom::cloth {

void PressureSettings::validate(const std::string& file, const std::string& where) const {
  auto show = [](double v) {
    char s[32];
    std::snprintf(s, sizeof s, "%.9g", v);
    return std::string(s);
  };
  auto check = [&](const char* field, double value, double lo, double hi) {
    if (!std::isfinite(value)) throw Error(file, where + "." + field, "must be a finite number");
    if (!(value >= lo && value <= hi))
      throw Error(file, where + "." + field,
                  "must be in [" + show(lo) + ", " + show(hi) + "] Pa (got " + show(value) + ")");
  };
  check("overpressure", overpressure, -1e7, 1e7);
  check("ambient", ambient, 0.0, 1e8);
  if (ideal_gas && !(ambient + overpressure > 0.0))
    throw Error(file, where + ".overpressure",
                "the gas needs a positive absolute pressure: ambient + overpressure must be > 0 (got " +
                    show(ambient + overpressure) + " Pa)");
}

std::string closed_mesh_problem(int num_edges, int num_interior_edges) {
  if (num_edges == num_interior_edges) return "";
  return "pressure needs a closed mesh (every edge shared by two triangles); this one has " +
         std::to_string(num_edges - num_interior_edges) + " open edges";
}

PressureTerm::PressureTerm(const PressureSettings& s, std::vector<Tri> triangles, const Vec3s& rest_positions)
    : s_(s), triangles_(std::move(triangles)) {
  vertex_triangles_.resize(rest_positions.size());
  for (size_t t = 0; t < triangles_.size(); ++t)
    for (int v : triangles_[t]) vertex_triangles_[v].push_back(static_cast<int>(t));
  tri_force_.resize(triangles_.size());
  const double v0 = volume(rest_positions);
  orientation_ = v0 < 0.0 ? -1.0 : 1.0;
  rest_volume_ = std::abs(v0);
}

double PressureTerm::volume(const Vec3s& x) const {
  double v = 0.0;
  for (const Tri& t : triangles_) v += x[t[0]].dot(x[t[1]].cross(x[t[2]]));
  return orientation_ * v / 6.0;
}

double PressureTerm::pressure_at(double volume) const {
  if (!s_.ideal_gas) return s_.overpressure;
  // Boyle: (p_out + p_over) V_rest = p_in V. A volume collapsed to <= 0 has no meaning: hold the rest value.
  if (!(volume > 0.0)) return s_.overpressure;
  return (s_.ambient + s_.overpressure) * rest_volume_ / volume - s_.ambient;
}

void PressureTerm::add_forces(const EvalContext& c, Vec3s& f) const {
  const double dp = pressure_at(volume(c.x));
  // f_t / 3 = Δp N_t / 6 per vertex, N_t outward (header).
  const double k = orientation_ * dp / 6.0;
  const int nt = static_cast<int>(triangles_.size());
  const int nv = static_cast<int>(vertex_triangles_.size());
#pragma omp parallel num_threads(c.threads) if (c.threads > 1 && nv >= kParallelMinVertices)
  {
#pragma omp for schedule(static)
    for (int t = 0; t < nt; ++t) {
      const Tri& tri = triangles_[t];
      tri_force_[t] = k * (c.x[tri[1]] - c.x[tri[0]]).cross(c.x[tri[2]] - c.x[tri[0]]);
    }
    gather_triangle_forces(tri_force_, vertex_triangles_, f);
  }
}

}  // namespace loom::cloth
