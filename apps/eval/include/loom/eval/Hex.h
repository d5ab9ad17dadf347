#pragma once
// 64-bit values as 16 lower-case hex digits, the form run ids and checksums take in Loom's output files.
#include <cstdint>
#include <cstdio>
#include <string>

namespace loom::eval {

inline std::string hex(std::uint64_t v) {
  char s[17];
  std::snprintf(s, sizeof s, "%016llx", static_cast<unsigned long long>(v));
  return s;
}

}  // namespace loom::eval
