#pragma once
// Cell indices of the contact stages' uniform grids (FeatureContact.cpp, RealtimeBodyContact.cpp). Not
// installed.

namespace loom::collision {

// v clamped to [lo, hi] and truncated to int, clamped before the cast: a far-flung or NaN coordinate (NaN
// goes to lo) never reaches an out-of-range conversion, which is undefined behaviour.
inline int clamped_cell(double v, int lo, int hi) {
  if (!(v >= lo)) return lo;
  if (v >= hi) return hi;
  return static_cast<int>(v);
}

}  // namespace loom::collision
