#include "loom/cloth/Pins.h"

#include <algorithm>

namespace loom::cloth {

Vec3 Pin::target(double t) const {
  if (times.empty()) return anchor;
  if (t <= times.front()) return anchor + offsets.front();
  if (t >= times.back()) return anchor + offsets.back();
  const size_t k =
      std::upper_bound(times.begin(), times.end(), t) - times.begin();  // times[k-1] <= t < times[k]
  const double a = (t - times[k - 1]) / (times[k] - times[k - 1]);
  return anchor + (1.0 - a) * offsets[k - 1] + a * offsets[k];
}

}  // namespace loom::cloth
