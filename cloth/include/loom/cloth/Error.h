#pragma once
// loom::Error: the one exception type thrown at the boundary (scene, mesh and file loading). The message
// always names where the problem is (file, field or line) and what it is.
#include <stdexcept>
#include <string>

namespace loom {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(no_nul(message)) {}
  // "FILE: WHERE: PROBLEM", the shape every user-facing error takes. `where` is a JSON path
  // (`cloths[0].material.areal_density`), a line (`line 12`) or a field name; empty parts are left out.
  Error(const std::string& file, const std::string& where, const std::string& problem)
      : std::runtime_error(no_nul(compose(file, where, problem))) {}

 private:
  // what() is a C string: a NUL from an input (an OBJ line, a name) would end the message there; it is
  // shown as \x00 instead.
  static std::string no_nul(std::string m) {
    for (std::size_t p; (p = m.find('\0')) != std::string::npos;) m.replace(p, 1, "\\x00");
    return m;
  }
  static std::string compose(const std::string& file, const std::string& where, const std::string& problem) {
    std::string m;
    if (!file.empty()) m += file + ": ";
    if (!where.empty()) m += where + ": ";
    return m + problem;
  }
};

}  // namespace loom
