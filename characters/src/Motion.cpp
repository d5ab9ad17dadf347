#include "loom/characters/Motion.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iterator>
#include <limits>
#include <map>
#include <sstream>

#include "AssimpInput.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/InputFile.h"

namespace loom::characters {

namespace {

// A node's scale (rest matrix or scaling keys) is applied when it is uniform and positive, constant over
// the clip and at or above the skeleton's root (the first animated joint): it then multiplies the offsets and
// position keys of every joint below the node (the products within [kMinNodeScale, kMaxNodeScale]). Any
// other scale (zero, negative, uneven over the axes, animated, or one limb's inside the skeleton) changes the
// bones' shape or mirrors them, which a rigid skeleton cannot carry: it is refused by joint and key.
constexpr double kScaleTolerance = 1e-3;  // 1, relative: axes (and keys) this close count as equal
constexpr double kMinNodeScale = 1e-6, kMaxNodeScale = 1e6;  // 1, the applied scales' range

std::string show_vec(const Vec3& v) {
  char s[96];
  std::snprintf(s, sizeof s, "(%g, %g, %g)", v.x(), v.y(), v.z());
  return s;
}

// Why the scale `v` (per axis) is not one Loom applies ("" if it is: uniform, positive, in range).
std::string scale_problem(const Vec3& v) {
  if (!v.allFinite()) return "is not finite";
  if (!(v.minCoeff() > 0.0))
    return "is not positive (a zero scale collapses the bones, a negative one mirrors)";
  if (v.maxCoeff() > (1.0 + kScaleTolerance) * v.minCoeff())
    return "is uneven over the axes (a non-uniform scale changes the bones' shape)";
  const double s = v.mean();
  if (!(s >= kMinNodeScale && s <= kMaxNodeScale)) return "is outside [1e-06, 1e+06]";
  return "";
}

// The rest transform's rotation and translation, and its uniform scale (`scale`). `checked`: throws
// loom::Error naming the joint for a scale Loom does not apply (scale_problem) or a mirroring matrix; else
// (a node that neither moves nor carries a moving one: a mesh beside the skeleton) the scale is dropped.
Transform to_transform(const std::string& path, const std::string& joint, const aiMatrix4x4& m, bool checked,
                       double& scale) {
  Transform t = Transform::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) t.matrix()(r, c) = static_cast<double>(m[r][c]);
  // The polar decomposition A = (U V^T)(V S V^T): a rotation times a symmetric stretch with the singular
  // values S on its axes.
  const Eigen::Matrix3d a = t.linear();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(a, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vec3 sigma = svd.singularValues();
  std::string problem = scale_problem(sigma);
  if (problem.empty() && !(a.determinant() > 0.0)) problem = "mirrors (a negative scale)";
  if (checked && !problem.empty())
    throw Error(path, "joint '" + joint + "'",
                "the rest transform's scale " + show_vec(sigma) + " " + problem +
                    ": a clip's node scales must be uniform, positive and constant");
  scale = checked ? sigma.mean() : 1.0;
  t.linear() = svd.matrixU() * svd.matrixV().transpose();
  return t;
}

// Index k of the last key with times[k] <= tau and the blend weight towards key k+1 (0 at and past the ends).
std::pair<size_t, double> bracket(const std::vector<double>& times, double tau) {
  if (times.size() < 2 || tau <= times.front()) return {0, 0.0};
  if (tau >= times.back()) return {times.size() - 1, 0.0};
  const size_t k = static_cast<size_t>(std::upper_bound(times.begin(), times.end(), tau) - times.begin()) - 1;
  return {k, (tau - times[k]) / (times[k + 1] - times[k])};
}

// The readers recurse per joint level, so a crafted file nested thousands deep would exhaust the stack: a
// BVH's brace depth is checked before assimp reads it, and every format's node tree after
// (read_with_assimp, kMaxJointDepth).
constexpr double kMaxPosition = 1e6;  // m, a joint's offset or position key after the clip's scale
// m/s, a joint's speed between two position keys after the clip's scale, as for a collider's keyframes:
// faster is a teleport (a corrupt or spliced key), not motion a cloth can follow.
constexpr double kMaxKeySpeed = 1e4;

// The formats a clip may be in (lower case): skeleton and animation formats; assimp's other readers make
// scenes without a skeleton (meshes, cameras) whose errors would only confuse.
const char* const kMotionFormats[] = {".bvh", ".fbx", ".dae", ".zae", ".gltf", ".glb"};

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// A BVH by its extension in any case, or by its first word (assimp's reader takes either).
bool is_bvh(const std::string& path) {
  if (lower_extension(path) == ".bvh") return true;
  std::ifstream f(path, std::ios::binary);
  std::string word;
  f >> std::setw(16) >> word;
  return word == "HIERARCHY";
}

void check_format(const std::string& path) {
  const std::string ext = lower_extension(path);
  std::string list;
  for (const char* f : kMotionFormats) {
    if (ext == f) return;
    list += std::string(list.empty() ? "" : ", ") + f;
  }
  throw Error(path, "",
              "cannot read motion: '" + ext + "' is not a motion format Loom reads (" + list +
                  ", in any letter case)");
}

// A number as the BVH reader's parser takes it and Loom keeps it: an optional sign, digits with an optional
// decimal point (at least one digit), an optional exponent with digits; "1e", "--1", "nan", "inf" and
// "0x10" are not numbers here (the reader stops on some with no line, reads others as non-finite).
bool bvh_number(const std::string& text, size_t begin, size_t end) {
  size_t k = begin;
  if (k < end && (text[k] == '+' || text[k] == '-')) ++k;
  size_t digits = 0;
  while (k < end && std::isdigit(static_cast<unsigned char>(text[k]))) ++k, ++digits;
  if (k < end && text[k] == '.') ++k;
  while (k < end && std::isdigit(static_cast<unsigned char>(text[k]))) ++k, ++digits;
  if (digits == 0) return false;
  if (k < end && (text[k] == 'e' || text[k] == 'E')) {
    ++k;
    if (k < end && (text[k] == '+' || text[k] == '-')) ++k;
    size_t exponent = 0;
    while (k < end && std::isdigit(static_cast<unsigned char>(text[k]))) ++k, ++exponent;
    if (exponent == 0) return false;
  }
  return k == end;
}

// 1-based line of the character at `at`.
unsigned long long line_number(const std::string& text, size_t at) {
  return 1 + static_cast<unsigned long long>(
                 std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

// The MOTION lines from `at` (just past the frame time): the rest of the frame time's line is empty, then
// one line per frame (blank lines skipped), each holding exactly `channels` numbers, `frames` lines in all;
// one more (Frames one short, as in the Biovision sample Boxing_Toes.bvh) is tolerated, and not read.
void check_bvh_frame_lines(const std::string& path, const std::string& text, size_t at,
                           unsigned long long frames, unsigned long long channels) {
  unsigned long long line = 1 + static_cast<unsigned long long>(std::count(
                                    text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
  unsigned long long seen = 0;  // frame lines
  for (bool first = true; at < text.size(); first = false, ++line) {
    const size_t end = std::min(text.find('\n', at), text.size());
    unsigned long long numbers = 0;
    for (size_t k = at; k < end;) {
      while (k < end && std::isspace(static_cast<unsigned char>(text[k]))) ++k;
      if (k == end) break;
      ++numbers;
      const size_t start = k;
      while (k < end && !std::isspace(static_cast<unsigned char>(text[k]))) ++k;
      if (!bvh_number(text, start, k))
        throw Error(path, "line " + std::to_string(line),
                    "value " + std::to_string(numbers) + " of the line, '" +
                        show_value(text.substr(start, k - start), 40) + "', is not a decimal number");
      if (!(std::abs(std::strtod(text.substr(start, k - start).c_str(), nullptr)) <=
            std::numeric_limits<float>::max()))
        throw Error(path, "line " + std::to_string(line),
                    "value " + std::to_string(numbers) + " of the line, '" +
                        show_value(text.substr(start, k - start), 40) +
                        "', is past the 3.4e38 the reader's 32-bit floats hold");
    }
    at = end + 1;
    if (numbers == 0) continue;
    const std::string where = "line " + std::to_string(line);
    if (first) throw Error(path, where, "numbers after the frame time (each frame is a line of its own)");
    if (++seen > frames + 1)
      throw Error(path, where,
                  "frame line " + std::to_string(seen) + ", but Frames says " + std::to_string(frames) +
                      " (one frame line past the count is read as an exporter's off-by-one and ignored)");
    if (numbers != channels)
      throw Error(path, where,
                  "frame " + std::to_string(seen) + " holds " + std::to_string(numbers) +
                      " numbers, but the joints' CHANNELS add up to " + std::to_string(channels) +
                      " (one frame per line)");
  }
  if (seen < frames)
    throw Error(path, "Frames",
                "says " + std::to_string(frames) + " frames but the MOTION section holds " +
                    std::to_string(seen) + " frame lines (of " + std::to_string(channels) + " numbers each)");
}

void check_bvh_nesting(const std::string& path) {
  if (!is_bvh(path)) return;
  const std::string text = read_input_file(path);  // a regular file of bounded size (InputFile.h)
  // Frames are lines: a carriage return must end a line with its line feed (CRLF); a lone one (old Mac
  // line ends) would join every frame into one line.
  for (size_t cr = text.find('\r'); cr != std::string::npos; cr = text.find('\r', cr + 1))
    if (cr + 1 == text.size() || text[cr + 1] != '\n')
      throw Error(path, "line " + std::to_string(line_number(text, cr)),
                  "a carriage return without a line feed (old Mac line ends): BVH lines end with LF or CRLF; "
                  "convert the file's line ends");
  // The file as whitespace-separated tokens, as assimp's BVH reader reads it (line breaks mean nothing).
  size_t at = 0;
  auto skip = [&]() {  // to the end of the next token; false at the end of the file
    while (at < text.size() && std::isspace(static_cast<unsigned char>(text[at]))) ++at;
    const size_t start = at;
    while (at < text.size() && !std::isspace(static_cast<unsigned char>(text[at]))) ++at;
    return at > start;
  };
  auto next = [&]() {  // the next token ("" at the end of the file)
    if (!skip()) return std::string();
    size_t start = at;
    while (start > 0 && !std::isspace(static_cast<unsigned char>(text[start - 1]))) --start;
    return text.substr(start, at - start);
  };
  int depth = 0;
  bool opened = false;
  unsigned long long channels = 0;  // numbers per frame: the sum of every joint's CHANNELS count
  std::string joint;                // the name of the joint whose block is being read
  for (std::string tok = next(); !tok.empty(); tok = next()) {
    if (tok == "{" && ++depth > kMaxJointDepth)
      throw Error(path, "HIERARCHY",
                  "joints nest more than " + std::to_string(kMaxJointDepth) + " levels deep");
    opened = opened || tok == "{";
    if (tok == "}") --depth;
    if (tok == "CHANNELS") {
      const std::string n = next();
      if (n.empty() || n.size() > 2 || n.find_first_not_of("0123456789") != std::string::npos)
        throw Error(path, "CHANNELS", "expected a channel count in [0, 99] (got '" + n + "')");
      channels += std::stoull(n);
      // Each channel at most once per joint: a repeated one would take two of the frame's numbers for one
      // degree of freedom (the reader keeps the last), silently shifting what the others mean.
      const size_t after = at;
      std::vector<std::string> names;
      for (unsigned long long k = 0; k < std::stoull(n); ++k) {
        names.push_back(next());
        for (size_t i = 0; i + 1 < names.size(); ++i)
          if (!names.back().empty() && names[i] == names.back())
            throw Error(path,
                        "line " + std::to_string(
                                      1 + std::count(text.begin(),
                                                     text.begin() + static_cast<std::ptrdiff_t>(at), '\n')),
                        "joint '" + joint + "': channel '" + names.back() +
                            "' is given twice in its CHANNELS (each channel at most once per joint)");
      }
      at = after;
    }
    if (tok == "OFFSET") {  // three numbers
      for (int k = 0; k < 3; ++k) {
        const std::string n = next();
        if (!bvh_number(n, 0, n.size()))
          throw Error(
              path, "line " + std::to_string(line_number(text, at)),
              "joint '" + joint + "': OFFSET needs three decimal numbers (got '" + show_value(n, 40) + "')");
      }
    }
    if (tok == "ROOT" || tok == "JOINT") {  // its name, read ahead (a nameless joint's "{" stays a token)
      const size_t after = at;
      joint = next();
      at = after;
    }
    if (opened && depth == 0) break;  // the root joint's block has closed: MOTION follows
  }
  // "Frames: N" is what the reader reserves memory for, and the MOTION numbers are read as a stream of
  // CHANNELS numbers per frame: one frame per line (the BVH layout), each line exactly the joints' CHANNELS
  // count and exactly Frames lines, so a count that disagrees with the data is refused by line instead of
  // read misaligned (every joint after the disagreement taking its neighbour's angles).
  std::string tok = next();
  while (!tok.empty() && tok != "Frames:") tok = next();
  if (tok.empty()) return;  // the reader names what is missing
  const std::string count = next();
  if (count.empty() || count.size() > 19 || count.find_first_not_of("0123456789") != std::string::npos)
    throw Error(path, "Frames", "expected a whole number of frames (got '" + count + "')");
  const unsigned long long frames = std::stoull(count);
  // assimp's reader makes one key out of no data for "Frames: 0" (and a clip of 2^32 - 1 frame times).
  if (frames == 0) throw Error(path, "Frames", "the MOTION section holds no frame (Frames must be >= 1)");
  if (next() != "Frame" || next() != "Time:") return;  // the reader names what is missing
  const std::string frame_time = next();  // its range is checked against the animation's rate after reading
  if (!bvh_number(frame_time, 0, frame_time.size()))
    throw Error(path, "Frame Time",
                "expected a decimal number of seconds (got '" + show_value(frame_time, 40) + "')");
  check_bvh_frame_lines(path, text, at, frames, channels);
}

void check_settings(const std::string& path, const MotionSettings& settings) {
  if (!(settings.speed > 0.0 && settings.speed <= 100.0)) throw Error(path, "speed", "must be in (0, 100]");
  if (!(std::abs(settings.start) <= 1e6)) throw Error(path, "start", "must be within +-1e6 s");
  if (!(settings.scale >= 0.0) || !std::isfinite(settings.scale)) throw Error(path, "scale", "must be >= 0");
  if (!(settings.height > 0.0)) throw Error(path, "height", "must be > 0");
}

// Ticks per second of the animation's key times (assimp's default 25 without animation or rate).
double ticks_per_second(const std::string& path, const aiAnimation* anim) {
  // A BVH's "Frame Time" is 1 / mTicksPerSecond: zero, negative or non-finite is refused, not defaulted;
  // "Frames: 0" leaves no keys.
  const bool bvh = is_bvh(path);
  if (bvh && anim &&
      !(std::isfinite(anim->mTicksPerSecond) && anim->mTicksPerSecond >= 1.0 / 3600.0 &&
        anim->mTicksPerSecond < 1e6))
    throw Error(path, "Frame Time", "must be in [1e-06, 3600] seconds");
  if (bvh) {
    bool keys = false;
    for (unsigned c = 0; anim && c < anim->mNumChannels; ++c)
      keys = keys || anim->mChannels[c]->mNumPositionKeys > 0 || anim->mChannels[c]->mNumRotationKeys > 0;
    if (!keys) throw Error(path, "Frames", "the MOTION section holds no frame (Frames must be >= 1)");
  }
  return anim && anim->mTicksPerSecond > 0.0 ? anim->mTicksPerSecond : 25.0;  // assimp's default
}

// What a non-finite key read from a file was: the reader keeps values as 32-bit floats.
constexpr const char* kPastFloats =
    " (as read: a NaN or infinity, or a number past the 3.4e38 of the reader's "
    "32-bit floats)";

// The keys of one joint's channel, times in seconds (key time / tps).
JointTrack read_track(const std::string& path, const std::string& joint, const aiNodeAnim* ch, double tps) {
  JointTrack track;
  // Keys must be finite with times that never go back (bracket() searches them); a file that says
  // otherwise (a corrupt or cut number, 1e999) is refused here, before any pose can turn non-finite.
  auto bad_key = [&](const char* kind, unsigned k, const std::vector<double>& times) {
    const double t = times.back();
    const std::string key = std::string(kind) + " key " + std::to_string(k);
    if (!std::isfinite(t))
      throw Error(path, "joint '" + joint + "'", key + ": its time is not finite" + kPastFloats);
    // A clip's time line starts at 0 (glTF 2.0 3.11: animation input values are >= 0), so its length is
    // its last key time: a key before 0 would make the clip's length and its playback disagree.
    if (t < 0.0) {
      std::ostringstream why;
      why << key << ": its time " << t << " s is negative (a clip's key times start at 0 or later)";
      throw Error(path, "joint '" + joint + "'", why.str());
    }
    if (times.size() > 1 && t < times[times.size() - 2]) {
      std::ostringstream why;
      why << key << ": its time " << t << " s comes before the previous key's " << times[times.size() - 2]
          << " s (key times never go back)";
      throw Error(path, "joint '" + joint + "'", why.str());
    }
  };
  for (unsigned k = 0; k < ch->mNumPositionKeys; ++k) {
    const aiVectorKey& key = ch->mPositionKeys[k];
    track.position_times.push_back(key.mTime / tps);
    track.positions.emplace_back(key.mValue.x, key.mValue.y, key.mValue.z);
    bad_key("position", k, track.position_times);
    if (!track.positions.back().allFinite())
      throw Error(path, "joint '" + joint + "'",
                  "position key " + std::to_string(k) + " is not finite" + kPastFloats);
  }
  for (unsigned k = 0; k < ch->mNumRotationKeys; ++k) {
    const aiQuatKey& key = ch->mRotationKeys[k];
    track.rotation_times.push_back(key.mTime / tps);
    const Quat q(key.mValue.w, key.mValue.x, key.mValue.y, key.mValue.z);
    bad_key("rotation", k, track.rotation_times);
    if (!q.coeffs().allFinite() || !(q.norm() > 0.0))
      throw Error(path, "joint '" + joint + "'",
                  "rotation key " + std::to_string(k) + " is not a finite rotation");
    track.rotations.push_back(q.normalized());
  }
  for (unsigned k = 0; k < ch->mNumScalingKeys; ++k) {
    const aiVectorKey& key = ch->mScalingKeys[k];
    const Vec3 v(key.mValue.x, key.mValue.y, key.mValue.z);
    std::string problem = scale_problem(v);
    if (problem.empty() && k > 0) {
      const Vec3 first(ch->mScalingKeys[0].mValue.x, ch->mScalingKeys[0].mValue.y,
                       ch->mScalingKeys[0].mValue.z);
      if (std::abs(v.mean() - first.mean()) > kScaleTolerance * first.mean())
        problem = "differs from key 0 " + show_vec(first) + " (an animated scale changes the bones' length)";
    }
    if (!problem.empty())
      throw Error(path, "joint '" + joint + "'",
                  "scale key " + std::to_string(k) + " " + show_vec(v) + " " + problem +
                      ": a clip's node scales must be uniform, positive and constant");
    if (k == 0) track.scale = v.mean();
  }
  return track;
}

// The node hierarchy below `node`, depth-first (parents before children), into joints and tracks;
// `duration` (s) grows to the last key time seen.
struct HierarchyReader {
  const std::string& path;
  const std::map<std::string, const aiNodeAnim*>& channels;
  double tps;
  std::vector<Joint>& joints;
  std::vector<JointTrack>& tracks;
  double& duration;

  // Whether the node or one below it is animated: its scale then moves the skeleton.
  bool carries(const aiNode* node) {
    auto [it, added] = carrying.emplace(node, false);
    if (!added) return it->second;
    bool out = channels.count(node->mName.C_Str()) > 0;
    for (unsigned c = 0; c < node->mNumChildren && !out; ++c) out = carries(node->mChildren[c]);
    return carrying[node] = out;
  }
  std::map<const aiNode*, bool> carrying = {};

  // `above`: the product of the uniform scales of the nodes above (the frame the node's offset is in).
  // `in_skeleton`: an animated joint lies above the node.
  void walk(const aiNode* node, int parent, double above, bool in_skeleton) {
    Joint j;
    j.name = node->mName.C_Str();
    j.parent = parent;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c)
        if (!std::isfinite(node->mTransformation[r][c]))
          throw Error(path, "joint '" + j.name + "'", "the rest transform (OFFSET) is not finite");
    double own = 1.0;  // the node's own uniform scale: its children's offsets are in its scaled frame
    j.rest = to_transform(path, j.name, node->mTransformation, in_skeleton || carries(node), own);
    JointTrack track;
    auto it = channels.find(j.name);
    if (it != channels.end()) {
      j.animated = true;
      track = read_track(path, j.name, it->second, tps);
      if (!track.position_times.empty()) duration = std::max(duration, track.position_times.back());
      if (!track.rotation_times.empty()) duration = std::max(duration, track.rotation_times.back());
      if (it->second->mNumScalingKeys > 0) own = track.scale;  // the keys replace the rest transform
    }
    // Below an animated joint a scale would resize one limb against the rest of the figure (the skin's
    // bind pose and the capsule radii assume the skeleton's proportions): only the skeleton's root and the
    // nodes above it may scale (a unit conversion on an armature).
    if (in_skeleton && std::abs(own - 1.0) > kScaleTolerance)
      throw Error(
          path, "joint '" + j.name + "'",
          "its " +
              std::string(j.animated && it->second->mNumScalingKeys > 0 ? "scale keys" : "rest transform") +
              " scale it by " + std::to_string(own) +
              " inside the skeleton: a clip may scale only at or above its root joint");
    j.rest.translation() *= above;
    for (Vec3& p : track.positions) p *= above;
    const double below = above * own;
    if (!(below >= kMinNodeScale && below <= kMaxNodeScale))
      throw Error(path, "joint '" + j.name + "'",
                  "the scales of the nodes down to it multiply to " + std::to_string(below) +
                      ", outside [1e-06, 1e+06]");
    const int index = static_cast<int>(joints.size());
    joints.push_back(j);
    tracks.push_back(std::move(track));
    for (unsigned c = 0; c < node->mNumChildren; ++c)
      walk(node->mChildren[c], index, below, in_skeleton || j.animated);
  }
};

}  // namespace

MemoryEstimate estimate_import_memory(const std::string& path) {
  const double bytes = static_cast<double>(import_source_bytes(path));
  char basis[96];
  std::snprintf(basis, sizeof basis, "%.3g MB read by the import, %.0f bytes held per byte", bytes / 1e6,
                kImportBytesPerByte);
  return {bytes * kImportBytesPerByte, basis};
}

MemoryEstimate estimate_clip_memory(const std::string& path) {
  std::error_code ec;
  // Only a regular file is opened here (a FIFO would block): anything else is refused by loading.
  if (!std::filesystem::is_regular_file(path, ec)) return {};
  if (!is_bvh(path)) return estimate_import_memory(path);
  const double size = static_cast<double>(std::filesystem::file_size(path, ec));
  if (ec) return {};
  // The header as the reader splits it: whitespace-separated words (a word read at most 64 bytes at a time).
  std::ifstream in(path, std::ios::binary);
  std::string word;
  double channels = 0.0, joints = 0.0, frames = -1.0;
  while (in >> std::setw(64) >> word) {
    if (word == "ROOT" || word == "JOINT") joints += 1.0;
    if (word == "CHANNELS" && in >> std::setw(64) >> word && word.size() <= 2 &&
        word.find_first_not_of("0123456789") == std::string::npos)
      channels += std::stod(word);
    if (word == "Frames:") {
      if (in >> std::setw(64) >> word && !word.empty() && word.size() <= 19 &&
          word.find_first_not_of("0123456789") == std::string::npos)
        frames = std::stod(word);
      break;
    }
  }
  // A header without a frame count or channels: the reader refuses it (its text is all it holds).
  if (frames < 0.0 || channels == 0.0) return {size, "the file's text"};
  // A count past what the file's lines can hold (a number and a space each) is refused by its lines.
  frames = std::min(frames, size / (2.0 * channels));
  char basis[128];
  std::snprintf(basis, sizeof basis, "%.0f frames of %.0f joints and %.0f channels", frames, joints,
                channels);
  return {frames * (joints * kBvhBytesPerJointFrame + channels * kBvhBytesPerValue) + size, basis};
}

Motion Motion::load(const std::string& path, const MotionSettings& settings) {
  check_settings(path, settings);
  try {  // a regular file of bounded size (InputFile.h) before assimp or the nesting check reads it
    check_input_file(path);
  } catch (const Error& e) {  // "PATH: cannot open it: <the system's reason>" (open_error_text)
    const std::string what = e.what(), head = path + ": ";
    throw Error(
        path, "",
        "cannot read motion: " + (what.compare(0, head.size(), head) == 0 ? what.substr(head.size()) : what));
  }
  check_format(path);
  check_bvh_nesting(path);
  Motion m;
  Assimp::Importer importer;
  // A whole scene (every pointer and index checked, nodes at most kMaxJointDepth deep) or an Error.
  const aiScene* scene = read_with_assimp(importer, path, 0, "motion", m.files_);

  m.source_ = path;
  m.settings_ = settings;
  const aiAnimation* anim = scene->mNumAnimations > 0 ? scene->mAnimations[0] : nullptr;
  std::map<std::string, const aiNodeAnim*> channels;
  if (anim)
    for (unsigned c = 0; c < anim->mNumChannels; ++c)
      channels[anim->mChannels[c]->mNodeName.C_Str()] = anim->mChannels[c];
  const double tps = ticks_per_second(path, anim);

  HierarchyReader reader{path, channels, tps, m.joints_, m.tracks_, m.duration_};
  reader.walk(scene->mRootNode, -1, 1.0, false);
  // Joints are found by name (garment attachments, capsule radii, skins): a name given twice is ambiguous.
  std::map<std::string, int> seen;
  for (int k = 0; k < m.num_joints(); ++k)
    if (!m.joints_[k].name.empty() && !seen.emplace(m.joints_[k].name, k).second)
      throw Error(path, "joint '" + m.joints_[k].name + "'",
                  "the name is given twice (joints " + std::to_string(seen[m.joints_[k].name]) + " and " +
                      std::to_string(k) + "): joints are found by name");
  m.root_ = -1;
  for (int k = 0; k < m.num_joints() && m.root_ < 0; ++k)
    if (m.joints_[k].animated) m.root_ = k;
  // A clip moves a skeleton: a file whose animation moves none of its nodes (no animation, or only morph
  // target weights) is refused here rather than read as a pose the scene's other fields are blamed for.
  if (m.root_ < 0)
    throw Error(path, "",
                std::string("holds no animated skeleton (") +
                    (anim ? "its animation moves none of its nodes" : "no animation") +
                    "): a motion clip needs keys that move its joints");
  m.set_units();
  m.set_root_motion();
  return m;
}

void Motion::set_units() {
  // Units: the rest pose's height (y extent of every joint at or below the root) becomes settings.height.
  std::vector<Transform> g(joints_.size());
  double ymin = std::numeric_limits<double>::infinity(), ymax = -ymin;
  for (int k = 0; k < num_joints(); ++k) {
    const int p = joints_[k].parent;
    g[k] = p < 0 ? joints_[k].rest : g[p] * joints_[k].rest;
    ymin = std::min(ymin, g[k].translation().y());
    ymax = std::max(ymax, g[k].translation().y());
  }
  if (settings_.scale > 0.0) {
    scale_ = settings_.scale;
  } else {
    if (!(ymax - ymin > 0.0))
      throw Error(source_, "scale", "the rest pose has no height; give 'scale' explicitly");
    if (!std::isfinite(ymax - ymin)) throw Error(source_, "scale", "the rest pose's height is not finite");
    scale_ = settings_.height / (ymax - ymin);
  }
  rest_height_ = (ymax - ymin) * scale_;
  for (Joint& j : joints_) j.rest.translation() *= scale_;
  for (JointTrack& t : tracks_)
    for (Vec3& p : t.positions) p *= scale_;
  // Joint positions (in metres, after the scale) within kMaxPosition, so the colliders posed from them stay
  // where double arithmetic is exact to well under a millimetre; a clip past it is refused by its channel.
  const char* kAxis[3] = {"Xposition", "Yposition", "Zposition"};
  for (int k = 0; k < num_joints(); ++k) {
    const Vec3 o = joints_[k].rest.translation();
    for (int a = 0; a < 3; ++a)
      if (!(std::abs(o[a]) <= kMaxPosition))
        throw Error(source_, "joint '" + joints_[k].name + "' OFFSET",
                    "is " + std::to_string(o[a]) + " m on " + "xyz"[a] + " after the clip's scale " +
                        std::to_string(scale_) + ": joint positions must be within 1e6 m");
    const JointTrack& t = tracks_[k];
    for (size_t f = 0; f < t.positions.size(); ++f)
      for (int a = 0; a < 3; ++a)
        if (!(std::abs(t.positions[f][a]) <= kMaxPosition)) {
          char v[32];
          std::snprintf(v, sizeof v, "%g", t.positions[f][a]);
          throw Error(source_, "joint '" + joints_[k].name + "' " + kAxis[a],
                      "frame " + std::to_string(f + 1) + " places it " + v + " m (after the clip's scale " +
                          std::to_string(scale_) + ") from the origin: joint positions must be within 1e6 m");
        }
    for (size_t f = 1; f < t.positions.size(); ++f) {
      const double dt = t.position_times[f] - t.position_times[f - 1];
      const double d = (t.positions[f] - t.positions[f - 1]).norm();
      if (dt > 0.0 && d > kMaxKeySpeed * dt) {
        char v[96];
        std::snprintf(v, sizeof v, "%g m in %g s (%g m/s", d, dt, d / dt);
        throw Error(source_, "joint '" + joints_[k].name + "' position",
                    "frame " + std::to_string(f + 1) + " jumps " + v + " after the clip's scale " +
                        std::to_string(scale_) + "): a joint may move at most 1e4 m/s between keys");
      }
    }
  }
}

void Motion::set_root_motion() {
  // Root motion bookkeeping (clip values, before placement).
  if (duration_ > 0.0 && settings_.loop) {
    const Vec3 a = local(root_, 0.0).translation(), b = local(root_, duration_).translation();
    cycle_shift_ = Vec3(b.x() - a.x(), 0.0, b.z() - a.z());
  }
  const double tau0 = settings_.loop && duration_ > 0.0
                          ? settings_.start - std::floor(settings_.start / duration_) * duration_
                          : std::clamp(settings_.start, 0.0, duration_);
  root_start_ = local(root_, tau0).translation();
  if (settings_.place) {
    placement_ = Vec3::Zero();
    std::vector<Transform> pose0;
    pose(0.0, pose0);
    double low = std::numeric_limits<double>::infinity();
    for (const Transform& t : pose0) low = std::min(low, t.translation().y());
    const Vec3 root = pose0[root_].translation();
    placement_ = Vec3(-root.x(), -low, -root.z());
  }
}

int Motion::find(const std::string& name) const {
  for (int k = 0; k < num_joints(); ++k)
    if (joints_[k].name == name) return k;
  return -1;
}

Transform Motion::local(int joint, double tau) const {
  const Joint& j = joints_[joint];
  if (!j.animated) return j.rest;
  const JointTrack& t = tracks_[joint];
  Transform out = Transform::Identity();
  if (t.positions.empty()) {
    out.translation() = j.rest.translation();
  } else {
    const auto [k, a] = bracket(t.position_times, tau);
    out.translation() =
        a == 0.0 ? t.positions[k] : ((1.0 - a) * t.positions[k] + a * t.positions[k + 1]).eval();
  }
  if (t.rotations.empty()) {
    out.linear() = j.rest.linear();
  } else {
    const auto [k, a] = bracket(t.rotation_times, tau);
    // Shortest-arc spherical interpolation (Shoemake 1985, "Animating rotation with quaternion curves").
    const Quat q = a == 0.0 ? t.rotations[k] : t.rotations[k].slerp(a, t.rotations[k + 1]);
    out.linear() = q.toRotationMatrix();
  }
  return out;
}

std::vector<double> Motion::played_samples(double rate) const {
  const double clip_span = settings_.loop ? duration_ : std::max(0.0, duration_ - settings_.start);  // s
  std::size_t keys = 2;
  for (const JointTrack& t : tracks_)
    keys = std::max({keys, t.position_times.size(), t.rotation_times.size()});
  const double by_keys = static_cast<double>(kSamplesPerKeyInterval) * static_cast<double>(keys - 1);
  // NaN-safe: a rate times a span that is not a number falls back to one interval.
  const double count = std::max(1.0, std::min(std::ceil(clip_span * rate), by_keys));
  const int samples = static_cast<int>(count);
  const double span = clip_span / settings_.speed;  // s of playback
  std::vector<double> times(static_cast<std::size_t>(samples) + 1);
  for (int k = 0; k <= samples; ++k) times[static_cast<std::size_t>(k)] = span * k / samples;
  return times;
}

void Motion::clip_pose(double tau, std::vector<Transform>& global) const {
  global.resize(joints_.size());
  for (int k = 0; k < num_joints(); ++k) {
    const int p = joints_[k].parent;
    global[k] = p < 0 ? local(k, tau) : global[p] * local(k, tau);
  }
}

void Motion::pose(double t, std::vector<Transform>& global) const {
  double tau = clip_time(t);
  Vec3 shift = Vec3::Zero();
  if (settings_.loop && duration_ > 0.0) {
    const double cycles = std::floor(tau / duration_);
    tau -= cycles * duration_;
    shift = cycles * cycle_shift_;
  } else {
    tau = std::clamp(tau, 0.0, duration_);
  }
  global.resize(joints_.size());
  for (int k = 0; k < num_joints(); ++k) {
    const int p = joints_[k].parent;
    Transform l = local(k, tau);
    if (k == root_) {
      if (settings_.root_motion) {
        l.translation() += shift;
      } else {
        l.translation().x() = root_start_.x();
        l.translation().z() = root_start_.z();
      }
    }
    global[k] = p < 0 ? l : global[p] * l;
  }
  for (Transform& g : global) g.translation() += placement_;
}

}  // namespace loom::characters
