// Hybrid detail on a character scene: a coarse cape shown as its curved-face surface stays close
// to a full simulation at the refined resolution once both have settled, costs a fraction of it, and the
// detail surface moves continuously with the coarse mesh. CI size: the cape at 0.125 m edges (6 x 7 nodes)
// with 1 level against 0.0625 m (11 x 13); the full size (2 levels against 0.03125 m, 21 x 25) is
// `build/bench/loom_bench_hybrid_character`.
#include <gtest/gtest.h>

#include <cstdio>

#include "HybridCharacter.h"

namespace {

TEST(HybridCharacter, CapeDetailStaysCloseToAFineSimulationWhenSettled) {
  const int frames = 150;  // 2.5 s
  const loom::test::HybridCharacterResult r = loom::test::measure_hybrid_character(0.125, 1, frames);
  std::printf(
      "hybrid cape on 01_01 (held still, leaning back 30 deg), %d frames: coarse %d + 1 level vs fine %d "
      "vertices: RMS %.4f m, max "
      "%.4f m; CPU %.3f s vs %.3f s (ratio %.3f); worst per-frame detail/coarse move %.3f; end speeds %.2g / "
      "%.2g m/s; fine cape moved up to %.3f m\n",
      frames, r.coarse_vertices, r.fine_vertices, r.rms, r.max, r.coarse_cpu, r.fine_cpu,
      r.coarse_cpu / r.fine_cpu, r.worst_move_ratio, r.coarse_speed, r.fine_speed, r.sag);
  EXPECT_EQ(r.coarse_vertices, 6 * 7);
  EXPECT_EQ(r.fine_vertices, 11 * 13);
  EXPECT_GT(r.sag, 0.05);           // it did fall onto the back (not a comparison of two still sheets)
  EXPECT_LT(r.coarse_speed, 0.01);  // m/s: settled
  EXPECT_LT(r.fine_speed, 0.01);
  EXPECT_LT(r.rms, 0.03);  // m, on a 0.75 m cape
  EXPECT_LT(r.max, 0.08);
  EXPECT_LT(r.worst_move_ratio, 2.0);  // no popping
}

}  // namespace
