#pragma once

// Constants shared by the cloth library's translation units (inline variables: one definition however many
// files include this, also when the build merges several files into one).
namespace loom::cloth {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kTwoPi = 2.0 * kPi;

// Loops over vertices or springs shorter than this run on one thread: a parallel region costs more than the
// work it would split. Results do not depend on it.
inline constexpr int kMinParallel = 512;

}  // namespace loom::cloth
