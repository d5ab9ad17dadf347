#pragma once
// Assembly of per-triangle Jacobian blocks shared by the triangle terms (BaraffWitkinTerm, CorotatedFemTerm).
#include <array>
#include <vector>

#include "loom/cloth/BlockGather.h"
#include "loom/cloth/BlockMatrix.h"
#include "loom/cloth/BlockScatter.h"

namespace loom::cloth {

// Adds every triangle's 9 df/dx and df/dv blocks (block 3m+n couples corner m to corner n) into dfdx / dfdv
// (either may be null; df/dv only when want_v). `blocks(k, kx, kv)` fills triangle k's blocks. One thread:
// one pass, no scratch. More: the blocks are computed in parallel into `dx_scratch` / `dv_scratch`, then
// added block by block in triangle order by `gather_x` / `gather_v` (BlockGather.h, rows in parallel), so
// both paths add the same blocks in the same order (bit-identical for any thread count).
template <class Triangle, class Blocks>
void assemble_triangle_jacobians(const std::vector<Triangle>& tris, int threads, bool want_v, BlockScatter& scatter,
                                 BlockGather& gather_x, BlockGather& gather_v, std::vector<Mat3>& dx_scratch, std::vector<Mat3>& dv_scratch, BlockMatrix* dfdx,
                                 BlockMatrix* dfdv, const Blocks& blocks) {
  const int nt = static_cast<int>(tris.size());
  auto add = [&](int k, const Mat3* kx, const Mat3* kv) {
    const auto& v = tris[k].v;
    for (int m = 0; m < 3; ++m)
      for (int n = 0; n < 3; ++n) {
        const int q = 9 * k + 3 * m + n;
        if (dfdx) scatter.add(*dfdx, q, v[m], v[n], kx[3 * m + n]);
        if (want_v) scatter.add(*dfdv, q, v[m], v[n], kv[3 * m + n]);
      }
  };
  if (threads <= 1) {
    Mat3 kx[9], kv[9];
    for (int k = 0; k < nt; ++k) {
      blocks(k, kx, kv);
      add(k, kx, kv);
    }
    return;
  }
  dx_scratch.resize(9 * tris.size());
  dv_scratch.resize(9 * tris.size());
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int k = 0; k < nt; ++k) blocks(k, &dx_scratch[9 * k], &dv_scratch[9 * k]);
  auto gather = [&](BlockGather& g, BlockMatrix& m, const std::vector<Mat3>& src) {
    if (!g.ready(m, 9 * nt))
      g.build(m, 9 * nt, [&](const auto& emit) {
        for (int k = 0; k < nt; ++k)
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) emit(tris[k].v[a], tris[k].v[b], 9 * k + 3 * a + b, false);
      });
    g.add(m, src, threads);
  };
  if (dfdx) gather(gather_x, *dfdx, dx_scratch);
  if (want_v) gather(gather_v, *dfdv, dv_scratch);
}

}  // namespace loom::cloth
