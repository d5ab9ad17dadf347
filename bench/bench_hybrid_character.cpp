// loom_bench_hybrid_character: the hybrid detail on a character scene at full size — a coarse
// cape on CMU 01_01 (held still in the clip's last pose, leaning back 30°: the cape lies on the back) shown
// with `levels` levels of curved faces against a full simulation at the refined resolution, both settled;
// distance, CPU cost and continuity. The measurement is
// tests/characters/HybridCharacter.h (the test runs it at CI size).
//
//   loom_bench_hybrid_character [--coarse M] [--levels L] [--frames N]   (defaults 0.125 m, 2, 150)
#include <cstdio>
#include <cstdlib>
#include <string>

#include "HybridCharacter.h"
#include "loom/cloth/Error.h"

int main(int argc, char** argv) {
  double coarse = 0.125;
  int levels = 2, frames = 150;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) {
      std::fprintf(stderr, "loom_bench_hybrid_character: %s needs a value\n", a.c_str());
      return 2;
    }
    const char* v = argv[++i];
    if (a == "--coarse")
      coarse = std::atof(v);
    else if (a == "--levels")
      levels = std::atoi(v);
    else if (a == "--frames")
      frames = std::atoi(v);
    else {
      std::fprintf(stderr, "loom_bench_hybrid_character: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  if (!(coarse > 0.0) || levels < 1 || levels > 5 || frames < 1) {
    std::fprintf(stderr,
                 "loom_bench_hybrid_character: need --coarse > 0, --levels in [1, 5], --frames >= 1\n");
    return 2;
  }
  try {
    const loom::test::HybridCharacterResult r = loom::test::measure_hybrid_character(coarse, levels, frames);
    std::printf(
        "hybrid cape on 01_01 (held still, leaning back 30 deg), %d frames (%.2f s), implicit Euler 4 "
        "substeps, drag 1 kg/(m^2 s)\n",
        frames, frames / 60.0);
    std::printf(
        "  coarse %.4g m edges, %d vertices + %d levels of curved faces vs a full simulation of %d "
        "vertices\n",
        coarse, r.coarse_vertices, levels, r.fine_vertices);
    std::printf("  point-to-surface distance, both ways: RMS %.4f m, max %.4f m\n", r.rms, r.max);
    std::printf("  CPU: coarse + detail %.3f s, fine %.3f s, ratio %.4f\n", r.coarse_cpu, r.fine_cpu,
                r.coarse_cpu / r.fine_cpu);
    std::printf("  worst per-frame move, detail surface / coarse mesh: %.3f\n", r.worst_move_ratio);
    std::printf(
        "  largest vertex speed over the last frame: coarse %.3g m/s, fine %.3g m/s; fine cape moved up to "
        "%.3f m from its start\n",
        r.coarse_speed, r.fine_speed, r.sag);
  } catch (const loom::Error& e) {
    std::fprintf(stderr, "loom_bench_hybrid_character: %s\n", e.what());
    return 1;
  }
  return 0;
}
