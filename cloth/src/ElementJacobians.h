#pragma once
// Assembly of per-element Jacobian blocks shared by the element terms: triangles (BaraffWitkinTerm,
// CorotatedFemTerm, 3 corners) and bending hinges (DihedralBendingTerm, 4 corners).
#include <array>
#include <tuple>
#include <vector>

#include "loom/cloth/BlockGather.h"
#include "loom/cloth/BlockMatrix.h"
#include "loom/cloth/BlockScatter.h"

namespace loom::cloth {

// Adds every element's C x C df/dx and df/dv blocks (C = the size of the std::array element.v of corners;
// block C m + n couples corner m to corner n) into dfdx / dfdv (either may be null; df/dv only when want_v).
// `blocks(k, kx, kv)` fills element k's blocks (kv is always writable). One thread: one pass, no scratch.
// More: the blocks are computed in parallel into `dx_scratch` / `dv_scratch`, then added block by block in
// element order by `gather_x` / `gather_v` (BlockGather.h, rows in parallel), so both paths add the same
// blocks in the same order (bit-identical for any thread count) and no part of the assembly runs on one
// thread only.
template <class Element, class Blocks>
void assemble_element_jacobians(const std::vector<Element>& elements, int threads, bool want_v,
                                BlockScatter& scatter, BlockGather& gather_x, BlockGather& gather_v,
                                std::vector<Mat3>& dx_scratch, std::vector<Mat3>& dv_scratch,
                                BlockMatrix* dfdx, BlockMatrix* dfdv, const Blocks& blocks) {
  constexpr int C = static_cast<int>(std::tuple_size<decltype(Element::v)>::value);  // corners
  constexpr int B = C * C;
  const int ne = static_cast<int>(elements.size());
  if (threads <= 1) {
    Mat3 kx[B], kv[B];
    for (int k = 0; k < ne; ++k) {
      blocks(k, kx, kv);
      const auto& v = elements[k].v;
      for (int m = 0; m < C; ++m)
        for (int n = 0; n < C; ++n) {
          const int q = B * k + C * m + n;
          if (dfdx) scatter.add(*dfdx, q, v[m], v[n], kx[C * m + n]);
          if (want_v) scatter.add(*dfdv, q, v[m], v[n], kv[C * m + n]);
        }
    }
    return;
  }
  if (dfdx) dx_scratch.resize(static_cast<size_t>(B) * ne);
  if (want_v) dv_scratch.resize(static_cast<size_t>(B) * ne);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int k = 0; k < ne; ++k) {
    Mat3 kx_unused[B], kv_unused[B];
    blocks(k, dfdx ? &dx_scratch[B * k] : kx_unused, want_v ? &dv_scratch[B * k] : kv_unused);
  }
  auto gather = [&](BlockGather& g, BlockMatrix& m, const std::vector<Mat3>& src) {
    if (!g.ready(m, B * ne))
      g.build(m, B * ne, [&](const auto& emit) {
        for (int k = 0; k < ne; ++k)
          for (int a = 0; a < C; ++a)
            for (int b = 0; b < C; ++b) emit(elements[k].v[a], elements[k].v[b], B * k + C * a + b, false);
      });
    g.add(m, src, threads);
  };
  if (dfdx) gather(gather_x, *dfdx, dx_scratch);
  if (want_v) gather(gather_v, *dfdv, dv_scratch);
}

}  // namespace loom::cloth
