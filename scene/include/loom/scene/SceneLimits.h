#pragma once
// The one place that bounds what a scene may ask for before anything is allocated or read: input files
// (regular files of bounded size), coordinates, frame and step counts, and the memory of the cloth
// vertices against what the machine has. Every refusal names the scene file, the field and the figure.
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string>

#include "loom/cloth/InputFile.h"
#include "loom/scene/JsonReader.h"

namespace loom::scene {

struct Scene;

constexpr std::uint64_t kMaxInputBytes = std::uint64_t(1) << 30;  // a scene, mesh or motion file: 1 GiB
// Nesting of arrays and objects in a scene file or a --set value (a scene nests a few levels; a parser's
// work and stack grow with the depth).
constexpr int kMaxJsonDepth = 100;
// A rotation's `degrees` (bodies, colliders): a turn written past a million degrees is no pose anyone means.
constexpr double kMaxDegrees = 1e6;
static_assert(kMaxInputBytes <= loom::kMaxInputFileBytes, "one bound for every input file");
constexpr double kMaxCoordinate = 1e6;  // m, |x| of a mesh size, origin, translation, anchor, collider
// m, a contact thickness: a collider's, a cloth material's, the collision block's (`thickness`, `layers`,
// the proximity gap) and a character's. It is the gap contact keeps between a cloth and what it touches, and
// cloth found inside it is pushed out to it in one step: a push of a few centimetres over a curved collider
// already stretches the sheet enough for its springs to fling it.
constexpr double kMaxContactThickness = 0.02;
// A Coulomb friction coefficient (kinetic or static); real fabric pairs lie below 2.
constexpr double kMaxFriction = 10.0;
constexpr double kMinMeshSize = 1e-3;      // m, a grid's side and an OBJ cloth's extent (after scale)
constexpr double kMinMeshScale = 1e-6;     // an OBJ cloth's or collider's scale
constexpr double kMaxAcceleration = 1e4;   // m/s^2, each component of gravity
constexpr double kMaxSpeed = 1e4;          // m/s, wind and keyframed motion; rad/s, a collider's spin rate
constexpr double kMaxStartSpeed = 1000.0;  // m/s, the speed a cloth or rigid body starts with (`velocity`)
// The smallest magnitude of a non-zero value of a field that must be positive or non-negative (a stiffness,
// time, length, density, coefficient): below it (a subnormal such as 1e-310 included) a value is no
// physical setting, and its reciprocal or square overflows the solver.
constexpr double kMinPositive = 1e-12;
// Bytes of a name that can become a file name (a cloth's `name` names its PC2 files) or a CSV cell.
constexpr std::size_t kMaxNameBytes = 200;
// A rigid body's mass (kg) and each of its sizes (m: radius, half height, half extent): Bullet stores them
// as floats, where a mass below ~1e-38 is 0 (a static body) and above ~3e38 infinite.
constexpr double kMinBodyMass = 1e-4, kMaxBodyMass = 1e6;
constexpr double kMinBodySize = 1e-3;
constexpr double kMaxCoefficient = 1e12;     // a material stiffness, damping or drag coefficient (own unit)
constexpr long long kMaxFrames = 10000000;   // frames of one run (duration x fps)
constexpr long long kMaxSubsteps = 1000000;  // solver steps per frame (frame time / solver.dt)
constexpr long long kMaxThreads = 4096;      // solver threads (`threads`, loom run --threads)
// Entries of a scene's `colliders` and of its `bodies`: every collider is tested against every cloth each
// step, so the cost per frame grows with the count (a game scene has tens to hundreds).
constexpr std::size_t kMaxColliders = 4096;
constexpr std::size_t kMaxBodies = 4096;
// Entries of `cloths`: each is its own solver, stage state and output files (a game scene has a handful;
// a crowd of garments is one cloth per garment).
constexpr std::size_t kMaxCloths = 4096;
// Bytes per cloth vertex of a simulation: the peak resident memory of implicit runs (the heaviest solvers)
// above the process's own, over the vertex count, rounded up (measured: docs/guarantees.md).
constexpr std::uint64_t kBytesPerVertex = 8192;

// Bytes per collider mesh triangle: the triangle, its share of the bounding volume hierarchies (Loom's and
// FCL's) and the distance structures, rounded up.
constexpr std::uint64_t kBytesPerColliderTriangle = 1024;

// The vertex (`v`) lines and the triangles its `f` lines make (a face of k corners: k - 2) of an OBJ file,
// counted in one streaming pass without building anything, and `bytes`, an upper bound of what reading it
// (cloth::read_obj_file) allocates at its peak, from the file's size and its lines of each kind: what a
// file will cost is known before it is parsed. Errors name the file.
struct ObjCounts {
  double vertices = 0.0;
  double triangles = 0.0;
  double bytes = 0.0;
};
ObjCounts count_obj_elements(const std::string& path);
// Refuses (naming `field`) an OBJ file whose reading (counts.bytes, held only while it is read) would pass
// memory_budget() with the scene's estimate so far.
void check_obj_reading(const Scene& scene, const std::string& field, const ObjCounts& counts);
// Adds `triangles` collider mesh triangles (of the collider at JSON path `field`) to the scene's count and
// refuses when, with the cloth vertices, the estimate exceeds memory_budget().
void reserve_collider_triangles(Scene& scene, const std::string& field, double triangles);
// Adds `bytes` that reading an input (a character's clip at JSON path `field`) will take to the scene's
// estimate and refuses as above when the total exceeds memory_budget(); `what` says what is read, ending in
// its verb ("the clip x.bvh (300000 frames of 96 channels) needs").
void reserve_input_bytes(Scene& scene, const std::string& field, double bytes, const std::string& what);

// Refuses (naming `file`, `field`) a path that is missing, not a regular file (a folder, a device such as
// /dev/zero, a pipe) or larger than kMaxInputBytes.
void check_input_file(const std::string& file, const std::string& field, const std::string& path);
// Resolves `path` as written in the scene (relative: to the scene file's folder), checks it as above and
// records it in scene.inputs (checkpoints hash every input).
std::string input_file(Scene& scene, const std::string& field, const std::string& path);
// What bounds the memory a run may use: the smallest of MemAvailable in /proc/meminfo, what the process's
// soft limits leave (RLIMIT_AS, `ulimit -v`, less the address space mapped now; RLIMIT_DATA, `ulimit -d`,
// less the data segment now) and LOOM_MEMORY_LIMIT; `source` names the one that gave `bytes`.
struct MemoryBudget {
  std::uint64_t bytes = 0;  // bytes; the largest 64-bit value when nothing is known
  std::string source;       // "MemAvailable", "RLIMIT_AS", "RLIMIT_DATA", "LOOM_MEMORY_LIMIT" or ""
};
// Whose memory a budget bounds: this process (what its limits leave above its current mapping), or a
// helper program it starts (ffmpeg: the limits whole, as the child inherits them with no mapping yet).
enum class MemoryOf { this_process, child_process };
MemoryBudget memory_budget_bound(MemoryOf of = MemoryOf::this_process);
// memory_budget_bound().bytes: the memory a run may use, in bytes.
std::uint64_t memory_budget();
// LOOM_MEMORY_LIMIT: nullopt when unset, else its value, a whole number of bytes in [1, 2^64 - 1] written
// in decimal digits only; anything else (abc, -1, 1.5, 1e9, past 64 bits) throws Error naming the variable.
std::optional<std::uint64_t> memory_limit_env();
// Adds `vertices` cloth vertices (of the cloth at JSON path `field`) to the scene's count and refuses when
// the estimate kBytesPerVertex x count exceeds memory_budget().
void reserve_vertices(Scene& scene, const std::string& field, double vertices);
// The size and geometry keys of the shapes colliders and bodies share (Collider.h): refuses, by the key,
// each of `keys` that `r` gives but `shape` does not use ("is not used by a plane body (shape "plane")").
// `kind`: "body" or "collider". Keys of other shapes would otherwise be read by no one.
void refuse_other_shape_keys(const JsonReader& r, const std::string& shape,
                             std::initializer_list<const char*> keys, const std::string& kind);
// "1.5 GB (set by LOOM_MEMORY_LIMIT) is available", "300 MB (under RLIMIT_AS, ulimit -v) is available":
// a budget as every message that gives a memory figure says it.
std::string available_memory_text(const MemoryBudget& budget);
// The one memory check of everything loom reads or builds: refuses (Error naming `file`, `field`) when
// `need` bytes (or a need that is not a number) exceed memory_budget_bound(). The message reads `what`
// (ending in its verb: "... needs") + " about <need> of memory" + `basis` + "; " + available_memory_text +
// ": " + `advice`.
void check_memory(const std::string& file, const std::string& field, double need, const std::string& what,
                  const std::string& advice, const std::string& basis = "",
                  MemoryOf of = MemoryOf::this_process);
// Counts and byte figures in messages are finite: at or above kMaxShownCount (and inf, NaN) they read
// "more than ...".
constexpr double kMaxShownCount = 1e15;
// "3.2e+07": an estimated count for messages; "more than 1e15" past kMaxShownCount.
std::string show_count(double count);
// "1.5 GB": a byte count for messages; "more than 1e6 GB" past kMaxShownCount bytes.
std::string show_bytes(double bytes);

}  // namespace loom::scene
