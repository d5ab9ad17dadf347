#pragma once
// AssimpInput: the one way loom::characters hands a file to assimp. Every file assimp opens for reading
// (the file itself and whatever it references: a glTF's external .bin buffers, a Collada's or FBX's linked
// files) goes through loom::check_input_file first (a regular file of at most 1 GiB: no folder, device
// such as /dev/zero, or pipe) and is recorded, so a checkpoint can hash every file a run depended on.
#include <assimp/DefaultIOSystem.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <string>
#include <vector>

namespace loom::characters {

class RecordingIOSystem : public Assimp::DefaultIOSystem {
 public:
  Assimp::IOStream* Open(const char* file, const char* mode = "rb") override;
  // By the file's status, never by opening it (assimp's own Exists opens the file: a pipe would block).
  bool Exists(const char* file) const override;
  // Files opened for reading, in first-open order, each once (as assimp named them).
  const std::vector<std::string>& files() const { return files_; }
  // The first file refused by check_input_file ("" if none) and why.
  const std::string& refused() const { return refused_; }
  const std::string& refusal() const { return refusal_; }

 private:
  std::vector<std::string> files_;
  std::string refused_, refusal_;
};

// Reads `path` with `importer` (post-processing `flags`) through a RecordingIOSystem and appends every file
// read to `files`. Throws loom::Error naming `path` (and the referenced file it refused, if any) when
// assimp cannot read it; `what` names the kind of content ("motion", "the mesh") in the message.
const aiScene* read_with_assimp(Assimp::Importer& importer, const std::string& path, unsigned flags,
                                const std::string& what, std::vector<std::string>& files);

}  // namespace loom::characters
