#include "AssimpInput.h"

#include <algorithm>
#include <filesystem>

#include "loom/cloth/Error.h"
#include "loom/cloth/InputFile.h"

namespace loom::characters {

Assimp::IOStream* RecordingIOSystem::Open(const char* file, const char* mode) {
  const std::string m = mode ? mode : "rb";
  if (file && m.find('w') == std::string::npos && m.find('a') == std::string::npos) {
    try {
      loom::check_input_file(file);
    } catch (const Error& e) {
      if (refused_.empty()) {
        refused_ = file;
        refusal_ = e.what();
      }
      return nullptr;
    }
    Assimp::IOStream* stream = Assimp::DefaultIOSystem::Open(file, mode);
    if (stream && std::find(files_.begin(), files_.end(), file) == files_.end()) files_.push_back(file);
    return stream;
  }
  return nullptr;  // assimp only reads here: a request to write is refused
}

bool RecordingIOSystem::Exists(const char* file) const {
  std::error_code ec;
  return file && std::filesystem::exists(file, ec);
}

const aiScene* read_with_assimp(Assimp::Importer& importer, const std::string& path, unsigned flags,
                                const std::string& what, std::vector<std::string>& files) {
  auto* io = new RecordingIOSystem;  // owned by the importer from here on
  importer.SetIOHandler(io);
  const aiScene* scene = importer.ReadFile(path, flags);
  for (const std::string& f : io->files())
    if (std::find(files.begin(), files.end(), f) == files.end()) files.push_back(f);
  if (!io->refused().empty() && io->refused() != path)
    throw Error(path, "", "cannot read " + what + ": a file it references is refused: " + io->refusal());
  if (!scene || !scene->mRootNode)
    throw Error(path, "", "cannot read " + what + ": " + importer.GetErrorString());
  return scene;
}

}  // namespace loom::characters
