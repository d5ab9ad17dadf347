#pragma once
// Motion: a skeleton (joint hierarchy with rest transforms) and its animation, loaded with assimp from BVH
// or any format assimp reads. Sampling at any time: rotations slerped, positions lerped between
// keys; units converted to metres; root motion on or off; looping; playback speed.
//
// Conventions: y is up (BVH). A joint's local transform is T(position) R(rotation), assimp's key order.
// A node's scale (rest matrix or scaling keys) must be uniform, positive and constant: it is applied by
// multiplying the offsets and position keys of the joints below it; any other scale is refused by joint and
// key. Global = parent global * local. Every length (key positions, rest offsets) is multiplied by
// `scale()` so the figure is in metres.
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::characters {

using cloth::Vec3;
using Quat = Eigen::Quaterniond;
using Transform = Eigen::Isometry3d;

struct MotionSettings {
  double scale = 0.0;       // m per file unit; 0: automatic, the rest pose's height becomes `height`
  double height = 1.7;      // m, target figure height of the automatic scale
  bool root_motion = true;  // false: the root's horizontal (x, z) translation stays at its start value
  bool loop = false;   // true: the clip repeats (root motion accumulates per cycle); false: holds the end
  double speed = 1.0;  // 1, clip seconds per simulated second
  double start = 0.0;  // s, clip time at simulated time 0
  bool place = true;   // true: at t = 0 the root is at x = z = 0 and the lowest joint at y = 0
};

struct Joint {
  std::string name;
  int parent = -1;                         // index into joints(), parents come before children
  Transform rest = Transform::Identity();  // local rest transform (m)
  bool animated = false;                   // has an animation channel (else it keeps `rest`)
};

// Keys of one animated joint (times in clip seconds, positions in metres).
struct JointTrack {
  std::vector<double> position_times;
  std::vector<Vec3> positions;
  std::vector<double> rotation_times;
  std::vector<Quat> rotations;
  double scale = 1.0;  // 1, the joint's uniform scale from its scaling keys (constant over the clip)
};

// What reading a file takes in memory, estimated before it is read, and what the estimate counts.
struct MemoryEstimate {
  double bytes = 0.0;  // bytes
  std::string basis;   // "300000 frames of 96 channels", "a 65 MB glTF with its buffers"
};
// What loading a BVH holds at its peak, above one byte per byte of the file: per joint and frame (assimp
// keeps a position and a rotation key for every animated node, the clip's track a time, position and
// rotation, whatever its channels) and per number of the MOTION section (measured: docs/guarantees.md).
constexpr double kBvhBytesPerJointFrame = 80.0;
constexpr double kBvhBytesPerValue = 20.0;
// Bytes per byte an assimp import reads (import_source_bytes) that loading holds at its peak (measured on a
// glTF clip: docs/guarantees.md).
constexpr double kImportBytesPerByte = 5.0;
// A BVH: Frames x (its joints x kBvhBytesPerJointFrame + their CHANNELS x kBvhBytesPerValue), from its
// header (read as a stream of words up to "Frames:"), plus the file's size; any other file: what its import
// reads x kImportBytesPerByte. A file that is not a regular file estimates 0 and is not opened (loading names
// it).
MemoryEstimate estimate_clip_memory(const std::string& path);
// Any file assimp reads (a mesh, a clip that is not a BVH): what its import reads x kImportBytesPerByte.
MemoryEstimate estimate_import_memory(const std::string& path);

class Motion {
 public:
  // Loads the file's node hierarchy and its first animation. Throws loom::Error naming the file on a read
  // failure, an empty hierarchy or a file whose animation moves none of its nodes (or that has none).
  static Motion load(const std::string& path, const MotionSettings& settings = {});

  const std::vector<Joint>& joints() const { return joints_; }
  int num_joints() const { return static_cast<int>(joints_.size()); }
  int find(const std::string& name) const;  // joint index, -1 if absent
  const JointTrack& track(int joint) const { return tracks_[joint]; }
  const MotionSettings& settings() const { return settings_; }
  const std::string& source() const { return source_; }
  // Every file the clip was read from: the file itself and any it references (a glTF's .bin buffers).
  const std::vector<std::string>& files() const { return files_; }
  double scale() const { return scale_; }              // m per file unit
  double duration() const { return duration_; }        // s, clip length (last key time)
  double rest_height() const { return rest_height_; }  // m, y extent of the rest pose's joints
  int root() const { return root_; }                   // the first animated joint (the skeleton's root)

  // Local transform of a joint at clip time tau (s), straight from the keys (clamped to the key range).
  Transform local(int joint, double tau) const;
  // Global transforms of every joint at clip time tau (s), without placement, looping or root handling.
  void clip_pose(double tau, std::vector<Transform>& global) const;
  // Global transforms at simulated time t (s): speed, start, looping, root motion and placement applied.
  void pose(double t, std::vector<Transform>& global) const;
  // Simulated times (s, from 0, ascending, at least two) that sample the clip as it plays: one cycle when
  // looping, else from `start` to the end. At most `rate` samples per second of clip time (the poses do not
  // depend on the playback speed) and at most kSamplesPerKeyInterval per interval between the keys of the
  // most-keyed joint (between keys a pose is an interpolation), so the count is bounded by the file's keys
  // whatever its times say.
  std::vector<double> played_samples(double rate) const;
  static constexpr int kSamplesPerKeyInterval = 8;
  // Clip time played at simulated time t (s), before wrapping (loop) or clamping.
  double clip_time(double t) const { return settings_.start + settings_.speed * t; }

 private:
  // Scales the rest pose and the position keys so that the rest pose is settings.height tall (or by
  // settings.scale); sets scale_ and rest_height_.
  void set_units();
  // The root's cycle shift (looping), its start translation and the placement (settings.place).
  void set_root_motion();

  std::string source_;
  std::vector<std::string> files_;
  MotionSettings settings_;
  std::vector<Joint> joints_;
  std::vector<JointTrack> tracks_;
  double scale_ = 1.0;
  double duration_ = 0.0;
  double rest_height_ = 0.0;
  int root_ = 0;
  Vec3 root_start_ = Vec3::Zero();   // m, the root's clip translation at settings.start
  Vec3 cycle_shift_ = Vec3::Zero();  // m, horizontal root displacement over one clip cycle (looping)
  Vec3 placement_ = Vec3::Zero();    // m, world offset applied to every joint (settings.place)
};

}  // namespace loom::characters
