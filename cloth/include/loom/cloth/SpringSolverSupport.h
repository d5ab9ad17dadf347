#pragma once
// What the spring-based solvers (pbd, xpbd, projective, desbrun) take from a cloth's terms: the springs of
// every SpringTerm (found by dynamic_cast) as constraints or as the constant part of the system matrix, and
// the forces of the non-elastic terms (gravity, drag) as external forces. Any other elastic term (Choi-Ko,
// Baraff-Witkin, ...) cannot be projected or filtered by these solvers: check_spring_terms() rejects it at
// set-up time, naming the term.
#include <Eigen/SparseCore>
#include <algorithm>
#include <vector>

#include "loom/cloth/Cloth.h"
#include "loom/cloth/SpringTerm.h"

namespace loom::cloth {

// True for terms the spring-based solvers apply as external forces: gravity and non-conservative terms.
bool is_external_term(const Term& term);
// Throws loom::Error("", "solver.method", ...) naming the first term that is neither a SpringTerm nor
// external, e.g. "method 'projective' cannot use term 'choi_ko' of cloth 'sheet'".
void check_spring_terms(const Cloth& cloth, const char* solver);
// The springs of every SpringTerm of the cloth, in term order.
std::vector<Spring> collect_springs(const Cloth& cloth);
// f = sum of the external terms' forces at (x, v, t) (the SpringTerms are left out).
void external_forces(const Cloth& cloth, const Vec3s& x, const Vec3s& v, double t, int threads, Vec3s& f);

// Index of every vertex among the free ones (inverse mass > 0), -1 for kinematic vertices.
std::vector<int> free_index(const ClothState& s, int* num_free);

// The scalar n_free x n_free matrix M + a L_k + b L_c over free vertices, with L_k = sum k_s A_s A_sᵀ and
// L_c = sum c_s A_s A_sᵀ (A_s: incidence vector of spring s; columns of kinematic vertices dropped).
// Liu et al. 2013 §4 (global matrix); Desbrun et al. 1999 (filter M - h² H, H = -L_k).
Eigen::SparseMatrix<double> spring_system_matrix(const ClothState& s, const std::vector<int>& index,
                                                 int num_free, const std::vector<Spring>& springs, double a,
                                                 double b);

// Greedy colouring of springs so that no two springs of one colour share a vertex: the springs of a colour
// can be projected in parallel with results independent of the thread count (PBD, XPBD).
std::vector<std::vector<int>> color_springs(int num_vertices, const std::vector<Spring>& springs);

}  // namespace loom::cloth
