#include "AssimpInput.h"

#include <pthread.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>

#include "ImportPrescan.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/InputFile.h"

namespace loom::characters {

namespace {

constexpr std::size_t kReaderStack = std::size_t(256) << 20;  // bytes; pages are committed when touched
constexpr long kMaxNodes = 10'000'000;                        // nodes visited in one scene

std::string show_bytes(std::uint64_t bytes) { return std::to_string(bytes / (1u << 20)) + " MiB"; }

// A file's stream whose reads count towards the import's byte bound: a read past it returns nothing.
class CountingStream : public Assimp::IOStream {
 public:
  CountingStream(Assimp::IOStream* inner, RecordingIOSystem& io, std::string file)
      : inner_(inner), io_(io), file_(std::move(file)) {}
  ~CountingStream() override { delete inner_; }
  size_t Read(void* buffer, size_t size, size_t count) override {
    if (size == 0 || count == 0) return 0;
    const std::uint64_t left = inner_->FileSize() > inner_->Tell() ? inner_->FileSize() - inner_->Tell() : 0;
    const std::uint64_t want = std::min<std::uint64_t>(std::uint64_t(size) * count, left);
    if (!io_.spend(file_, want)) return 0;
    return inner_->Read(buffer, size, count);
  }
  size_t Write(const void*, size_t, size_t) override { return 0; }
  aiReturn Seek(size_t offset, aiOrigin origin) override { return inner_->Seek(offset, origin); }
  size_t Tell() const override { return inner_->Tell(); }
  size_t FileSize() const override { return inner_->FileSize(); }
  void Flush() override {}

 private:
  Assimp::IOStream* inner_;
  RecordingIOSystem& io_;
  std::string file_;
};

std::uint32_t le32(const std::string& s, std::size_t at) {
  return std::uint32_t(static_cast<unsigned char>(s[at])) |
         std::uint32_t(static_cast<unsigned char>(s[at + 1])) << 8 |
         std::uint32_t(static_cast<unsigned char>(s[at + 2])) << 16 |
         std::uint32_t(static_cast<unsigned char>(s[at + 3])) << 24;
}
std::uint32_t le16(const std::string& s, std::size_t at) {
  return std::uint32_t(static_cast<unsigned char>(s[at])) |
         std::uint32_t(static_cast<unsigned char>(s[at + 1])) << 8;
}

// The bytes a zip archive unpacks to, by its central directory (the sizes the unzip reader allocates and
// fills; PKWARE APPNOTE 6.3, sections 4.3.12 and 4.3.16). Throws loom::Error naming `file` for a
// directory it cannot walk or a ZIP64 archive (sizes past 4 GiB).
std::uint64_t zip_unpacked_bytes(const std::string& file, const std::string& zip) {
  // The end-of-central-directory record: 22 bytes and a comment of at most 65535, searched from the end
  // as the unzip reader does.
  const std::size_t lowest = zip.size() > 22 + 65535 ? zip.size() - 22 - 65535 : 0;
  std::size_t end = std::string::npos;
  for (std::size_t at = zip.size() >= 22 ? zip.size() - 22 + 1 : 0; at-- > lowest;)
    if (zip.compare(at, 4, "PK\x05\x06") == 0) {
      end = at;
      break;
    }
  if (end == std::string::npos) throw Error(file, "", "a zip archive without its central directory");
  const std::uint32_t entries = le16(zip, end + 10), size = le32(zip, end + 12), offset = le32(zip, end + 16);
  if (entries == 0xffff || size == 0xffffffffu || offset == 0xffffffffu)
    throw Error(file, "", "a ZIP64 archive (entries past 4 GiB) is not read");
  if (std::uint64_t(offset) + size > end)
    throw Error(file, "", "the zip's central directory is out of range");
  std::uint64_t total = 0;
  std::size_t at = offset;
  for (std::uint32_t k = 0; k < entries; ++k) {
    if (at + 46 > end || zip.compare(at, 4, "PK\x01\x02") != 0)
      throw Error(file, "zip entry " + std::to_string(k), "the central directory is cut or corrupt");
    const std::uint32_t unpacked = le32(zip, at + 24);
    if (unpacked == 0xffffffffu) throw Error(file, "", "a ZIP64 archive (entries past 4 GiB) is not read");
    total += unpacked;
    at += 46 + le16(zip, at + 28) + le16(zip, at + 30) + le16(zip, at + 32);
  }
  return total;
}

std::uint64_t line_of(const std::string& text, std::size_t at) {
  return 1 + static_cast<std::uint64_t>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

// `mtllib` directives of an OBJ (a line's first word): assimp reads the named library once per directive.
void check_mtllib(const std::string& file, const std::string& text) {
  int count = 0;
  for (std::size_t at = 0; at < text.size();) {
    std::size_t word = at;
    while (word < text.size() && (text[word] == ' ' || text[word] == '\t')) ++word;
    if (text.compare(word, 6, "mtllib") == 0 && word + 6 < text.size() &&
        (text[word + 6] == ' ' || text[word + 6] == '\t') && ++count > kMaxMtllib)
      throw Error(file, "line " + std::to_string(line_of(text, word)),
                  "more than " + std::to_string(kMaxMtllib) +
                      " 'mtllib' directives (each makes the reader load a material library again)");
    const std::size_t next = text.find('\n', at);
    at = next == std::string::npos ? text.size() : next + 1;
  }
}

// What Open checks on the first opening of a file's content (throws loom::Error naming the file).
std::uint64_t check_content(const std::string& file) {
  std::string text = read_input_file(file);
  if (text.compare(0, 4, "PK\x03\x04") == 0) return zip_unpacked_bytes(file, text);
  // UTF-16 (by its byte order mark or a leading '<' code unit; XML readers take it): markup is ASCII, so
  // the low byte of each code unit is enough to see the elements.
  const bool le = text.compare(0, 2, "\xFF\xFE") == 0 || text.compare(0, 2, std::string("<\0", 2)) == 0;
  const bool be = text.compare(0, 2, "\xFE\xFF") == 0 || text.compare(0, 2, std::string("\0<", 2)) == 0;
  if (le || be) {
    std::string narrow(text.size() / 2, ' ');
    for (std::size_t k = 0; k < narrow.size(); ++k) narrow[k] = text[2 * k + (be ? 1 : 0)];
    text.swap(narrow);
    if (text.compare(0, 1, "\xFF") == 0 || text.compare(0, 1, "\xFE") == 0) text[0] = ' ';
  }
  std::size_t first = text.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  while (first < text.size() && std::isspace(static_cast<unsigned char>(text[first]))) ++first;
  if (first < text.size() && text[first] == '<') {
    const long deep = xml_too_deep(text, kMaxXmlDepth);
    if (deep >= 0)
      throw Error(file, "line " + std::to_string(line_of(text, static_cast<std::size_t>(deep))),
                  "XML elements nest more than " + std::to_string(kMaxXmlDepth) + " levels deep");
    check_collada_instances(file, text);  // ImportPrescan.h
  } else {
    check_mtllib(file, text);
    check_gltf_nodes(file, text);   // ImportPrescan.h
    check_fbx_nesting(file, text);  // ImportPrescan.h
  }
  return 0;
}

struct ImportJob {
  Assimp::Importer* importer;
  const char* path;
  unsigned flags;
  const aiScene* scene = nullptr;
  std::exception_ptr error;
};

void* run_import(void* arg) {
  auto* job = static_cast<ImportJob*>(arg);
  try {
    job->scene = job->importer->ReadFile(job->path, job->flags);
  } catch (...) {
    job->error = std::current_exception();
  }
  return nullptr;
}

// ReadFile on a thread with a kReaderStack stack (on the caller's if no such thread can be made).
const aiScene* import_on_large_stack(Assimp::Importer& importer, const std::string& path, unsigned flags) {
  ImportJob job{&importer, path.c_str(), flags, nullptr, nullptr};
  pthread_attr_t attr;
  pthread_t thread;
  bool started = false;
  if (pthread_attr_init(&attr) == 0) {
    started = pthread_attr_setstacksize(&attr, kReaderStack) == 0 &&
              pthread_create(&thread, &attr, run_import, &job) == 0;
    pthread_attr_destroy(&attr);
  }
  if (started)
    pthread_join(thread, nullptr);
  else
    run_import(&job);
  if (job.error) std::rethrow_exception(job.error);
  return job.scene;
}

// Everything Loom's readers follow in the scene is there: no null node, mesh, face index array, bone,
// animation or channel; indices in range; nodes nested at most kMaxJointDepth deep.
void check_scene(const std::string& path, const aiScene* scene) {
  auto missing = [&](const std::string& where, const std::string& what) {
    throw Error(path, where, what + " is missing (a null pointer in what the reader made of the file)");
  };
  if (scene->mNumMeshes > 0 && !scene->mMeshes) missing("meshes", "the mesh list");
  for (unsigned k = 0; k < scene->mNumMeshes; ++k) {
    const std::string where = "meshes[" + std::to_string(k) + "]";
    const aiMesh* m = scene->mMeshes[k];
    if (!m) missing(where, "the mesh");
    if (m->mNumVertices > 0 && !m->mVertices) missing(where, "the vertex array");
    if (m->mNumFaces > 0 && !m->mFaces) missing(where, "the face array");
    for (unsigned f = 0; f < m->mNumFaces; ++f) {
      const aiFace& face = m->mFaces[f];
      if (face.mNumIndices > 0 && !face.mIndices)
        missing(where + ".faces[" + std::to_string(f) + "]", "the index array");
      for (unsigned i = 0; i < face.mNumIndices; ++i)
        if (face.mIndices[i] >= m->mNumVertices)
          throw Error(path, where + ".faces[" + std::to_string(f) + "]",
                      "vertex " + std::to_string(face.mIndices[i]) + " does not exist (the mesh has " +
                          std::to_string(m->mNumVertices) + ")");
    }
    if (m->mNumBones > 0 && !m->mBones) missing(where, "the bone list");
    for (unsigned b = 0; b < m->mNumBones; ++b) {
      if (!m->mBones[b]) missing(where + ".bones[" + std::to_string(b) + "]", "the bone");
      if (m->mBones[b]->mNumWeights > 0 && !m->mBones[b]->mWeights)
        missing(where + ".bones[" + std::to_string(b) + "]", "the weight array");
    }
  }
  if (scene->mNumAnimations > 0 && !scene->mAnimations) missing("animations", "the animation list");
  for (unsigned a = 0; a < scene->mNumAnimations; ++a) {
    const std::string where = "animations[" + std::to_string(a) + "]";
    const aiAnimation* anim = scene->mAnimations[a];
    if (!anim) missing(where, "the animation");
    if (anim->mNumChannels > 0 && !anim->mChannels) missing(where, "the channel list");
    for (unsigned c = 0; c < anim->mNumChannels; ++c) {
      const aiNodeAnim* ch = anim->mChannels[c];
      const std::string at = where + ".channels[" + std::to_string(c) + "]";
      if (!ch) missing(at, "the channel");
      if ((ch->mNumPositionKeys > 0 && !ch->mPositionKeys) ||
          (ch->mNumRotationKeys > 0 && !ch->mRotationKeys) || (ch->mNumScalingKeys > 0 && !ch->mScalingKeys))
        missing(at, "a key array");
    }
  }
  std::vector<std::pair<const aiNode*, int>> stack{{scene->mRootNode, 1}};
  long visited = 0;
  while (!stack.empty()) {
    const auto [n, d] = stack.back();
    stack.pop_back();
    if (!n) missing("nodes", "a child node");
    if (d > kMaxJointDepth)
      throw Error(path, "HIERARCHY",
                  "joints nest more than " + std::to_string(kMaxJointDepth) + " levels deep");
    if (++visited > kMaxNodes)
      throw Error(path, "nodes", "more than " + std::to_string(kMaxNodes) + " nodes");
    const std::string name = n->mName.C_Str();
    if (n->mNumChildren > 0 && !n->mChildren) missing("node '" + name + "'", "the child list");
    if (n->mNumMeshes > 0 && !n->mMeshes) missing("node '" + name + "'", "the mesh index list");
    for (unsigned k = 0; k < n->mNumMeshes; ++k)
      if (n->mMeshes[k] >= scene->mNumMeshes)
        throw Error(path, "node '" + name + "'", "mesh " + std::to_string(n->mMeshes[k]) + " does not exist");
    for (unsigned c = 0; c < n->mNumChildren; ++c) stack.push_back({n->mChildren[c], d + 1});
  }
}

}  // namespace

long xml_too_deep(const std::string& text, int max_depth) {
  const std::size_t n = text.size();
  long depth = 0;
  auto skip_past = [&](std::size_t from, const char* end) {  // the index after `end`, or n
    const std::size_t at = text.find(end, from);
    return at == std::string::npos ? n : at + std::strlen(end);
  };
  for (std::size_t at = text.find('<'); at < n; at = text.find('<', at)) {
    if (text.compare(at, 4, "<!--") == 0) {
      at = skip_past(at + 4, "-->");
    } else if (text.compare(at, 9, "<![CDATA[") == 0) {
      at = skip_past(at + 9, "]]>");
    } else if (text.compare(at, 2, "<?") == 0) {
      at = skip_past(at + 2, "?>");
    } else if (text.compare(at, 2, "<!") == 0) {  // a declaration; its internal subset in [ ]
      int brackets = 0;
      for (++at; at < n && !(text[at] == '>' && brackets <= 0); ++at)
        brackets += text[at] == '[' ? 1 : text[at] == ']' ? -1 : 0;
      ++at;
    } else if (text.compare(at, 2, "</") == 0) {
      depth = std::max(0L, depth - 1);
      at = skip_past(at + 2, ">");
    } else {  // a start tag, to its '>' outside quoted values; "/>" closes it at once
      const std::size_t start = at;
      char quote = 0;
      for (++at; at < n && (quote || text[at] != '>'); ++at)
        if (quote ? text[at] == quote : text[at] == '"' || text[at] == '\'') quote = quote ? 0 : text[at];
      if (at < n && text[at - 1] == '/') {
        ++at;
        continue;
      }
      if (++depth > max_depth) return static_cast<long>(start);
      ++at;
    }
  }
  return -1;
}

bool RecordingIOSystem::spend(const std::string& file, std::uint64_t bytes) {
  if (spent_ + bytes <= kMaxImportBytes) {
    spent_ += bytes;
    return true;
  }
  refuse(file, file + ": the import would read more than " + show_bytes(kMaxImportBytes) +
                   " in all (every file it opens, each time, and what its archives unpack to)");
  return false;
}

void RecordingIOSystem::refuse(const std::string& file, const std::string& message) {
  if (!refused_.empty()) return;
  refused_ = file;
  refusal_ = message;
}

Assimp::IOStream* RecordingIOSystem::Open(const char* file, const char* mode) {
  const std::string m = mode ? mode : "rb";
  if (!file || m.find('w') != std::string::npos || m.find('a') != std::string::npos)
    return nullptr;                       // assimp only reads here: a request to write is refused
  if (!refused_.empty()) return nullptr;  // the import is refused already: nothing more is read
  try {
    loom::check_input_file(file);
    if (scanned_.insert(file).second) {
      const std::uint64_t unpacked = check_content(file);
      if (!spend(file, unpacked)) return nullptr;
    }
  } catch (const Error& e) {
    refuse(file, e.what());
    return nullptr;
  }
  Assimp::IOStream* stream = Assimp::DefaultIOSystem::Open(file, mode);
  if (!stream) return nullptr;
  if (std::find(files_.begin(), files_.end(), file) == files_.end()) files_.push_back(file);
  return new CountingStream(stream, *this, file);
}

bool RecordingIOSystem::Exists(const char* file) const {
  std::error_code ec;
  return file && std::filesystem::exists(file, ec);
}

const aiScene* read_with_assimp(Assimp::Importer& importer, const std::string& path, unsigned flags,
                                const std::string& what, std::vector<std::string>& files) {
  auto* io = new RecordingIOSystem;  // owned by the importer from here on
  importer.SetIOHandler(io);
  const aiScene* scene = import_on_large_stack(importer, path, flags);
  for (const std::string& f : io->files())
    if (std::find(files.begin(), files.end(), f) == files.end()) files.push_back(f);
  if (io->refused() == path) throw Error(io->refusal());
  if (!io->refused().empty())
    throw Error(path, "", "cannot read " + what + ": a file it references is refused: " + io->refusal());
  if (!scene || !scene->mRootNode)
    throw Error(path, "", "cannot read " + what + ": " + importer.GetErrorString());
  check_scene(path, scene);
  return scene;
}

}  // namespace loom::characters
