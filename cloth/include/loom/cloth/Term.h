#pragma once
// Term: one piece of physics (gravity, springs, drag, ...). Every term gives its energy, its forces and its
// 3x3 Jacobian blocks; solvers consume terms only through this interface (docs/architecture.md, "terms").
// Virtual dispatch happens per term, never per element.
#include <algorithm>
#include <utility>
#include <vector>

#include "loom/cloth/BlockMatrix.h"
#include "loom/cloth/Types.h"

namespace loom::cloth {

// What a term is evaluated at.
struct EvalContext {
  const Vec3s& x;   // m
  const Vec3s& v;   // m/s
  double t = 0.0;   // s
  int threads = 1;  // OpenMP threads for per-element loops
};

// How Jacobians are formed. Defaults give the exact derivatives (what the finite-difference tests check);
// implicit solvers ask for the symmetric, positive-definite-friendly variants.
struct JacobianOptions {
  bool clamp_compression = false;      // springs: clamp (1 - L/l) to >= 0 (as Blender does)
  bool damping_position_terms = true;  // include d(damping force)/dx (non-symmetric; usually dropped)
};

// Per-vertex loops shorter than this run on one thread: the fork/join costs more than the work (results do
// not depend on it: such loops are independent per vertex).
constexpr int kParallelMinVertices = 2048;

// Σ_{k<n} f(k), deterministically: the terms are added in fixed chunks of `Chunk`, then the chunk sums in
// order, so the result has the same bits for any thread count. Chunks run on several threads from
// kParallelMinVertices terms up (energies of large meshes: the implicit safeguard and line search evaluate
// them several times per step; the PCG's dot products). With at most one chunk it is the serial loop's sum,
// bit for bit. The parallel path keeps the chunk sums in `scratch` if given (no allocation per call), else in
// a local vector; the serial path needs neither.
template <int Chunk = 512, class F>
double chunked_sum(int n, int threads, const F& f, std::vector<double>* scratch = nullptr) {
  const int chunks = (n + Chunk - 1) / Chunk;
  auto chunk_sum = [&](int ch) {
    double acc = 0.0;
    const int end = std::min(n, (ch + 1) * Chunk);
    for (int k = ch * Chunk; k < end; ++k) acc += f(k);
    return acc;
  };
  double sum = 0.0;
  if (threads <= 1 || n < kParallelMinVertices) {
    for (int ch = 0; ch < chunks; ++ch) sum += chunk_sum(ch);
    return sum;
  }
  std::vector<double> local;
  std::vector<double>& partial = scratch ? *scratch : local;
  partial.resize(chunks);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int ch = 0; ch < chunks; ++ch) partial[ch] = chunk_sum(ch);
  for (int ch = 0; ch < chunks; ++ch) sum += partial[ch];
  return sum;
}

class Term {
 public:
  virtual ~Term() = default;
  virtual const char* name() const = 0;
  // Conservative terms have force = -grad(energy), a function of the positions alone (not of v or t: the
  // implicit safeguard reuses the energies of unchanged positions); the others (drag) return energy 0.
  virtual bool conservative() const { return true; }
  virtual double energy(const EvalContext& c) const = 0;              // J
  virtual void add_forces(const EvalContext& c, Vec3s& f) const = 0;  // N, accumulated into f
  // Vertex pairs this term couples in its Jacobians (for BlockMatrix's pattern).
  virtual void add_pattern(std::vector<std::pair<int, int>>& pairs) const { (void)pairs; }
  // Accumulates df/dx into dfdx and df/dv into dfdv (either may be null).
  virtual void add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                             BlockMatrix* dfdv) const = 0;
  // False when add_jacobians never adds to dfdv (the force does not depend on v): implicit solvers then skip
  // clearing and reading df/dv.
  virtual bool has_velocity_jacobian() const { return true; }
  // True when, under options o, every block add_jacobians adds is mirrored bit for bit: block (j, i) receives
  // the transpose of what (i, j) receives, in the same order, and diagonal blocks are symmetric. Implicit
  // solvers then skip symmetrising A (it would not change a bit).
  virtual bool symmetric_jacobians(const JacobianOptions& o) const {
    (void)o;
    return false;
  }
  // Work done by the last add_forces call, for the profile (elements evaluated).
  virtual long work_items() const { return 0; }
};

}  // namespace loom::cloth
