// libFuzzer target: the mocap loader (loom::characters::Motion::load, BVH through assimp). Any input
// must either load or throw loom::Error naming the file; anything else (crash, sanitizer report, another
// exception) is a bug. A clip that loads must pose finitely at any time, looped or not: a non-finite joint
// transform would reach the capsule colliders and the garments' pins, so it is a bug here too (trap).
// assimp picks the format by the file's extension, so each input is written to a per-process `.bvh` file.
// Coverage feedback comes from Loom's code only: Debian's libassimp is not instrumented.
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "loom/characters/Motion.h"
#include "loom/cloth/Error.h"

namespace {

void check_pose(const loom::characters::Motion& m, double t) {
  std::vector<loom::characters::Transform> g;
  m.pose(t, g);
  if (g.size() != static_cast<size_t>(m.num_joints())) __builtin_trap();
  for (const auto& x : g)
    if (!x.matrix().allFinite()) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > 64 * 1024) return 0;  // bounded work per iteration
  static const std::string path = "/tmp/loom_fuzz_bvh_" + std::to_string(getpid()) + ".bvh";
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  for (bool loop : {false, true}) {
    loom::characters::MotionSettings s;
    s.loop = loop;
    s.speed = 3.0;  // the stability suite's 3x clip
    s.start = 0.25;
    try {
      const auto m = loom::characters::Motion::load(path, s);
      if (!std::isfinite(m.scale()) || !(m.scale() > 0.0) || !std::isfinite(m.duration())) __builtin_trap();
      for (double t : {0.0, 0.01, 0.5 * m.duration(), m.duration(), 2.7 * m.duration() + 0.1})
        check_pose(m, t);
    } catch (const loom::Error&) {
      return 0;  // the same bytes fail the same way with loop on
    }
  }
  return 0;
}
