#include "loom/scene/SceneLimits.h"

#include <sys/resource.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <vector>

#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/InputFile.h"
#include "loom/scene/Scene.h"

namespace fs = std::filesystem;

namespace loom::scene {

void check_input_file(const std::string& file, const std::string& field, const std::string& path) {
  try {
    loom::check_input_file(path, kMaxInputBytes);
  } catch (const Error& e) {
    if (path == file && field.empty()) throw;
    throw Error(file, field, e.what());  // "scene.json: cloths[0].mesh.path: mesh.obj: no such file"
  }
}

std::string input_file(Scene& scene, const std::string& field, const std::string& path) {
  fs::path p(path);
  if (p.is_relative()) p = fs::path(scene.file).parent_path() / p;
  check_input_file(scene.file, field, p.string());
  scene.inputs.push_back(p.string());
  return p.string();
}

namespace {

// A "Key: N kB" field of a /proc file in bytes; nullopt when absent.
std::optional<std::uint64_t> proc_kb(const char* file, const std::string& field) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.compare(0, field.size(), field) != 0) continue;
    std::istringstream words(line.substr(field.size()));
    std::uint64_t kb = 0;
    if (words >> kb) return kb * 1024;
  }
  return std::nullopt;
}

// What the soft limit `resource` leaves above `used` bytes (the process's current mapping of that kind).
std::optional<std::uint64_t> rlimit_left(int resource, const std::optional<std::uint64_t>& used) {
  rlimit limit{};
  if (::getrlimit(resource, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return std::nullopt;
  const std::uint64_t cur = static_cast<std::uint64_t>(limit.rlim_cur), now = used.value_or(0);
  return cur > now ? cur - now : 0;
}

}  // namespace

MemoryBudget memory_budget_bound(MemoryOf of) {
  MemoryBudget b{std::numeric_limits<std::uint64_t>::max(), ""};
  auto take = [&b](const std::optional<std::uint64_t>& bytes, const char* source) {
    if (bytes && *bytes < b.bytes) b = {*bytes, source};
  };
  // A child process starts with no mapping of its own: the limits bound it whole.
  const bool self = of == MemoryOf::this_process;
  take(proc_kb("/proc/meminfo", "MemAvailable:"), "MemAvailable");
  take(rlimit_left(RLIMIT_AS,
                   self ? proc_kb("/proc/self/status", "VmSize:") : std::optional<std::uint64_t>(0)),
       "RLIMIT_AS");
  take(rlimit_left(RLIMIT_DATA,
                   self ? proc_kb("/proc/self/status", "VmData:") : std::optional<std::uint64_t>(0)),
       "RLIMIT_DATA");
  take(memory_limit_env(), "LOOM_MEMORY_LIMIT");
  return b;
}

std::uint64_t memory_budget() { return memory_budget_bound().bytes; }

std::optional<std::uint64_t> memory_limit_env() {
  const char* env = std::getenv("LOOM_MEMORY_LIMIT");
  if (!env) return std::nullopt;
  const std::string text = env;
  // Digits only (no sign, no space, no exponent, no fraction), at most 2^64 - 1.
  const bool digits =
      !text.empty() && text.size() <= 20 && text.find_first_not_of("0123456789") == std::string::npos;
  errno = 0;
  char* end = nullptr;
  const unsigned long long v = digits ? std::strtoull(text.c_str(), &end, 10) : 0;
  if (!digits || errno == ERANGE || v == 0)
    throw Error(
        "", "LOOM_MEMORY_LIMIT",
        "must be a whole number of bytes in [1, 18446744073709551615] (got '" + show_value(text) + "')");
  return static_cast<std::uint64_t>(v);
}

std::string show_count(double count) {
  if (!(count < kMaxShownCount)) return "more than 1e15";  // also inf and NaN: a message shows no inf
  char s[32];
  std::snprintf(s, sizeof s, "%.3g", count);
  return s;
}

std::string show_bytes(double bytes) {
  if (!(bytes < kMaxShownCount)) return "more than 1e6 GB";
  char s[48];
  if (bytes >= 1e9)
    std::snprintf(s, sizeof s, "%.3g GB", bytes / 1e9);
  else if (bytes >= 1e6)
    std::snprintf(s, sizeof s, "%.3g MB", bytes / 1e6);
  else
    std::snprintf(s, sizeof s, "%.0f bytes", bytes);
  return s;
}

namespace {

// The scene's estimate: its cloth vertices, collider triangles and read inputs so far.
double scene_bytes(const Scene& scene) {
  return scene.vertices * static_cast<double>(kBytesPerVertex) +
         scene.collider_triangles * static_cast<double>(kBytesPerColliderTriangle) + scene.input_bytes;
}

// "about 3.2e+07", or "more than 1e15" as show_count and show_bytes give it past their bound.
std::string about(const std::string& figure) {
  return figure.rfind("more than", 0) == 0 ? figure : "about " + figure;
}

// Refuses (naming `field`) the scene when its estimate, with `transient_bytes` held only for a while (a file
// being read), passes the budget: `what` says which count grew (ending in its verb), `advice` what lowers it.
void check_budget(const Scene& scene, const std::string& field, const std::string& what,
                  const std::string& advice, double transient_bytes = 0.0) {
  check_memory(scene.file, field, scene_bytes(scene) + transient_bytes, what, advice,
               " with the rest of the scene (" + std::to_string(kBytesPerVertex) +
                   " bytes per cloth vertex, " + std::to_string(kBytesPerColliderTriangle) +
                   " per collider triangle" +
                   (scene.input_bytes > 0.0 ? ", and what reading its clip takes" : "") + ")");
}

}  // namespace

std::string available_memory_text(const MemoryBudget& budget) {
  std::string why;
  if (budget.source == "LOOM_MEMORY_LIMIT") why = " (set by LOOM_MEMORY_LIMIT)";
  if (budget.source == "MemAvailable") why = " (MemAvailable in /proc/meminfo)";
  if (budget.source == "RLIMIT_AS") why = " (left under RLIMIT_AS, ulimit -v)";
  if (budget.source == "RLIMIT_DATA") why = " (left under RLIMIT_DATA, ulimit -d)";
  return show_bytes(static_cast<double>(budget.bytes)) + why + " is available";
}

void check_memory(const std::string& file, const std::string& field, double need, const std::string& what,
                  const std::string& advice, const std::string& basis, MemoryOf of) {
  const MemoryBudget budget = memory_budget_bound(of);
  // Also refused: a need that is not a number (the estimate of a degenerate field).
  if (!(need <= static_cast<double>(budget.bytes)))
    throw Error(file, field,
                what + " " + about(show_bytes(need)) + " of memory" + basis + "; " +
                    available_memory_text(budget) + ": " + advice);
}

void refuse_other_shape_keys(const JsonReader& r, const std::string& shape,
                             std::initializer_list<const char*> keys, const std::string& kind) {
  const bool listed = shape == "convex" || shape == "mesh";  // given by their vertices
  for (const char* key : keys) {
    const std::string k = key;
    const bool used = (k == "radius" && shape != "plane" && shape != "box" && !listed) ||
                      (k == "half_height" && (shape == "capsule" || shape == "cylinder")) ||
                      (k == "half_extents" && shape == "box") ||
                      ((k == "vertices" || k == "obj") && listed) || (k == "triangles" && shape == "mesh");
    if (!used && r.has(k))
      r.fail(k, "is not used by a " + shape + " " + kind + " (shape \"" + shape + "\"); remove it");
  }
}

void reserve_vertices(Scene& scene, const std::string& field, double vertices) {
  scene.vertices += vertices;
  check_budget(scene, field,
               "the scene's cloths would have " + about(show_count(scene.vertices)) + " vertices, which need",
               "use fewer nodes or a coarser resolution");
}

void reserve_collider_triangles(Scene& scene, const std::string& field, double triangles) {
  scene.collider_triangles += triangles;
  check_budget(scene, field,
               "the scene's collider meshes would have " + about(show_count(scene.collider_triangles)) +
                   " triangles, which need",
               "use a coarser collider mesh");
}

void reserve_input_bytes(Scene& scene, const std::string& field, double bytes, const std::string& what) {
  scene.input_bytes += bytes;
  check_budget(scene, field, what, "use a shorter clip (fewer frames or joints)");
}

ObjCounts count_obj_elements(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "", "cannot read");
  ObjCounts c;
  // Per line: its first token and how many follow it (a face's corners, a group's names).
  std::vector<char> buf(1 << 20);
  bool line_start = true, in_first = false, in_token = false;
  std::string first;
  double tokens = 0.0, file_bytes = 0.0;
  // The reader's allocations per line kind, bounded above (vectors grow by doubling, each heap block has a
  // 16-byte header): a position and its line number; a texture coordinate; a face (its record, its corner
  // list and its quoted text); a group line (its name list and each name).
  auto end_line = [&] {
    if (first == "v") {
      c.vertices += 1.0;
      c.bytes += 64.0;
    } else if (first == "vt") {
      c.bytes += 32.0;
    } else if (first == "f") {
      if (tokens >= 3.0) c.triangles += tokens - 2.0;
      c.bytes += 320.0 + 16.0 * tokens;
    } else if (first == "g") {
      c.bytes += 64.0 + 96.0 * std::max(tokens, 1.0);
    }
    line_start = true, in_first = false, in_token = false, tokens = 0.0;
    first.clear();
  };
  bool first_chunk = true;
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    const std::streamsize n = in.gcount();
    file_bytes += static_cast<double>(n);
    std::streamsize i = 0;
    // A UTF-8 byte order mark is not part of the first line (for_each_input_line, InputFile.h).
    if (first_chunk && n >= 3 && std::string(buf.data(), 3) == "\xef\xbb\xbf") i = 3;
    first_chunk = false;
    for (; i < n; ++i) {
      const char ch = buf[static_cast<size_t>(i)];
      // Lines and words as the OBJ reader splits them (ObjFile.cpp): a line ends at LF or a bare CR (CRLF
      // is then a line and an empty one), and every std::isspace character separates words.
      if (ch == '\n' || ch == '\r') {
        end_line();
        continue;
      }
      const bool space = ch == ' ' || ch == '\t' || ch == '\v' || ch == '\f';
      if (line_start && !space) {
        line_start = false;
        in_first = true;
      }
      if (in_first) {
        if (space)
          in_first = false;
        else if (first.size() < 3)
          first += ch;  // "v", "vt", "f", "g"; a longer keyword is none of them
        continue;
      }
      if (!space && !in_token) tokens += 1.0;
      in_token = !space;
    }
  }
  end_line();
  // The file's text, held while it is read, and the line being read.
  c.bytes += 2.0 * file_bytes;
  return c;
}

void check_obj_reading(const Scene& scene, const std::string& field, const ObjCounts& counts) {
  check_budget(scene, field,
               "reading its OBJ file (" + about(show_bytes(counts.bytes)) + " while it is read) needs",
               "use a smaller mesh file", counts.bytes);
}

}  // namespace loom::scene
