#pragma once
// Internals shared by the self-collision stage's phase files (SelfCollisionStage.cpp: set-up and the step;
// SelfCollisionCandidates.cpp: BVH pairs and features; SelfProximity.cpp: proximity impulses;
// SelfContinuousPass.cpp: continuous passes; ImpactZones.cpp: the fail-safe). Not installed.
#include <algorithm>
#include <chrono>
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::collision::self_collision_detail {

using loom::cloth::Vec3;
using loom::cloth::Vec3s;

// Adds the wall time of its scope to `ms` (ms): the stage's phase timers in the profile.
class PhaseTimer {
 public:
  explicit PhaseTimer(double& ms) : ms_(ms), start_(std::chrono::steady_clock::now()) {}
  ~PhaseTimer() {
    ms_ += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  double& ms_;
  std::chrono::steady_clock::time_point start_;
};

inline int find_root(std::vector<int>& parent, int v) {
  while (parent[v] != v) {
    parent[v] = parent[parent[v]];
    v = parent[v];
  }
  return v;
}

constexpr long kZoneCcdBoxes = 4096;  // the impact zones' budget of inclusion boxes per continuous test

// Unit vector along `d`, or along `fallback` oriented like `side` when d is (nearly) zero.
inline bool contact_normal(const Vec3& d, const Vec3& fallback, const Vec3& side, Vec3& n) {
  const double len = d.norm();
  if (len > 1e-12 * std::max(1.0, fallback.norm())) {
    n = d / len;
    return true;
  }
  const double fl = fallback.norm();
  if (!(fl > 0.0)) return false;
  n = fallback / fl;
  if (n.dot(side) < 0.0) n = -n;
  return true;
}

// A float at most d (d >= 0): float rounding is within 2^-24 relatively, the factor keeps it below.
inline float lower_float(double d) { return d > 0.0 ? static_cast<float>(d) * 0.999999f : 0.0f; }

// The per-chunk lists of a parallel loop joined in chunk order (the serial order, whatever the thread count).
template <class T>
std::vector<T> join_chunks(std::vector<std::vector<T>>& parts) {
  if (parts.size() == 1) return std::move(parts[0]);
  std::vector<T> out;
  size_t total = 0;
  for (const auto& p : parts) total += p.size();
  out.reserve(total);
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

// Runs body(begin, end, out) over contiguous chunks of [0, n) in parallel, each chunk appending to its own
// list, and returns the lists joined in chunk order: the serial order whatever the thread count. Below
// `serial_below` one chunk; else `per_thread` chunks per thread (dynamic schedule: chunks of uneven cost).
template <class T, class Body>
std::vector<T> in_chunks(long n, int threads, long serial_below, int per_thread, Body body) {
  const int chunks = n < serial_below ? 1 : std::max(1, threads) * per_thread;
  std::vector<std::vector<T>> parts(chunks);
#pragma omp parallel for num_threads(threads) if (threads > 1 && chunks > 1) schedule(dynamic, 1)
  for (int ch = 0; ch < chunks; ++ch) body(n * ch / chunks, n * (ch + 1) / chunks, parts[ch]);
  return join_chunks(parts);
}

// Per-contact velocity changes dv[4] (m/s) are applied per vertex: averaged over the vertex's contacts, in
// the contacts' (sorted) order, so the result does not depend on the thread count.
struct Impulse {  // a contact's velocity changes (m/s) of its four vertices; inactive: a hit without one
  int v[4] = {0, 0, 0, 0};
  Vec3 dv[4];
  bool active = false;
};

// Runs body(i, out) for every feature i in [0, n) (in_chunks): the impulses in the order of i whatever the
// thread count, with no per-feature storage (most features give nothing).
template <class Body>
std::vector<Impulse> collect_impulses(long n, int threads, Body body) {
  return in_chunks<Impulse>(n, threads, 4096, 8, [&](long begin, long end, std::vector<Impulse>& out) {
    for (long i = begin; i < end; ++i) body(i, out);
  });
}

// Applies the impulses (apply order: `imp`'s), x1 += h * (mean dv per vertex); marks moved vertices in
// `moved` when given (SelfProximity.cpp).
void apply_impulses(const std::vector<Impulse>& imp, double h, Vec3s& x1, std::vector<char>* moved);

}  // namespace loom::collision::self_collision_detail
