#include "loom/cloth/SpringSolverSupport.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <unordered_set>

#include "loom/cloth/Error.h"

namespace loom::cloth {

bool is_external_term(const Term& term) {
  return !term.conservative() || std::strcmp(term.name(), "gravity") == 0;
}

void check_spring_terms(const Cloth& cloth, const char* solver) {
  for (const auto& t : cloth.terms()) {
    if (dynamic_cast<const SpringTerm*>(t.get()) || is_external_term(*t)) continue;
    throw Error("", "solver.method",
                std::string("method '") + solver + "' cannot use term '" + t->name() + "' of cloth '" +
                    cloth.name() + "' (it takes springs, gravity and drag only)");
  }
}

std::vector<Spring> collect_springs(const Cloth& cloth) {
  std::vector<Spring> all;
  for (const auto& t : cloth.terms())
    if (const auto* st = dynamic_cast<const SpringTerm*>(t.get()))
      all.insert(all.end(), st->springs().begin(), st->springs().end());
  return all;
}

void external_forces(const Cloth& cloth, const Vec3s& x, const Vec3s& v, double t, int threads, Vec3s& f) {
  f.assign(x.size(), Vec3::Zero());
  const EvalContext ctx{x, v, t, threads};
  for (const auto& term : cloth.terms())
    if (!dynamic_cast<const SpringTerm*>(term.get())) term->add_forces(ctx, f);
}

std::vector<int> free_index(const ClothState& s, int* num_free) {
  std::vector<int> index(s.size(), -1);
  int n = 0;
  for (int i = 0; i < s.size(); ++i)
    if (s.inv_mass[i] > 0.0) index[i] = n++;
  *num_free = n;
  return index;
}

Eigen::SparseMatrix<double> spring_system_matrix(const ClothState& s, const std::vector<int>& index,
                                                 int num_free, const std::vector<Spring>& springs, double a,
                                                 double b) {
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(num_free + 4 * springs.size());
  for (int i = 0; i < s.size(); ++i)
    if (index[i] >= 0) trip.emplace_back(index[i], index[i], s.mass[i]);
  for (const Spring& sp : springs) {
    const double w = a * sp.k + b * sp.c;
    const int fi = index[sp.i], fj = index[sp.j];
    if (fi >= 0) trip.emplace_back(fi, fi, w);
    if (fj >= 0) trip.emplace_back(fj, fj, w);
    if (fi >= 0 && fj >= 0) {
      trip.emplace_back(fi, fj, -w);
      trip.emplace_back(fj, fi, -w);
    }
  }
  Eigen::SparseMatrix<double> m(num_free, num_free);
  m.setFromTriplets(trip.begin(), trip.end());
  return m;
}

std::vector<std::vector<int>> color_springs(int num_vertices, const std::vector<Spring>& springs) {
  // Each spring takes the lowest colour used by no other spring at either end (greedy, in spring order).
  // first_free[v]: the lowest colour not used at v, so every colour below max(first_free[i], first_free[j])
  // is taken; the (vertex, colour) pairs in use are hashed. Linear in the springs for any vertex valence.
  std::vector<std::vector<int>> colors;
  std::vector<int> first_free(num_vertices, 0);
  std::unordered_set<std::uint64_t> used;
  used.reserve(2 * springs.size());
  auto key = [](int v, int c) {
    return (static_cast<std::uint64_t>(v) << 32) | static_cast<std::uint32_t>(c);
  };
  for (int s = 0; s < static_cast<int>(springs.size()); ++s) {
    const int i = springs[s].i, j = springs[s].j;
    int c = std::max(first_free[i], first_free[j]);
    while (used.count(key(i, c)) || used.count(key(j, c))) ++c;
    if (c == static_cast<int>(colors.size())) colors.emplace_back();
    colors[c].push_back(s);
    for (int v : {i, j}) {
      used.insert(key(v, c));
      while (used.count(key(v, first_free[v]))) ++first_free[v];
    }
  }
  return colors;
}

}  // namespace loom::cloth
