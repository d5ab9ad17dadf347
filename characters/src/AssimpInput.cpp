#include "AssimpInput.h"

#include <pthread.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>

#include "ImportPrescan.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
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

struct ZipEntry {
  std::string name;
  std::uint32_t flags = 0, method = 0, packed = 0, unpacked = 0, local = 0;  // local: its header's offset
};

// A zip archive's entries by its central directory (PKWARE APPNOTE 6.3, sections 4.3.12 and 4.3.16), as
// the unzip reader finds them. Throws loom::Error naming `file` for a directory it cannot walk or a ZIP64
// archive (sizes past 4 GiB).
std::vector<ZipEntry> zip_entries(const std::string& file, const std::string& zip) {
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
  std::vector<ZipEntry> out;
  std::size_t at = offset;
  for (std::uint32_t k = 0; k < entries; ++k) {
    if (at + 46 > end || zip.compare(at, 4, "PK\x01\x02") != 0)
      throw Error(file, "zip entry " + std::to_string(k), "the central directory is cut or corrupt");
    ZipEntry e;
    e.flags = le16(zip, at + 8);
    e.method = le16(zip, at + 10);
    e.packed = le32(zip, at + 20);
    e.unpacked = le32(zip, at + 24);
    e.local = le32(zip, at + 42);
    if (e.unpacked == 0xffffffffu || e.packed == 0xffffffffu || e.local == 0xffffffffu)
      throw Error(file, "", "a ZIP64 archive (entries past 4 GiB) is not read");
    const std::size_t name = le16(zip, at + 28);
    e.name = zip.substr(std::min(at + 46, end), std::min<std::size_t>(name, end - std::min(at + 46, end)));
    out.push_back(std::move(e));
    at += 46 + name + le16(zip, at + 30) + le16(zip, at + 32);
  }
  return out;
}

// The XML element-depth check of one zip entry, inflated a piece at a time up to the size its directory
// gives, as the unzip reader hands it to assimp; a shallow entry's text (kept as it is read, within the
// import's byte budget) then gets the COLLADA instance-graph check. Entries named *.dae or *.xml and entries
// whose text starts with '<' (after a byte order mark and white space) are scanned; encrypted entries and
// methods other than stored and deflate (which the reader cannot unpack) are not. Throws loom::Error naming
// `file`, the entry and the line of the first element nested deeper than kMaxXmlDepth.
void check_zip_entry(const std::string& file, const std::string& zip, const ZipEntry& e) {
  if (std::uint64_t(e.local) + 30 > zip.size() || zip.compare(e.local, 4, "PK\x03\x04") != 0) return;
  // The unzip reader refuses an entry whose local header disagrees with the directory on its method, and
  // the importer then reports the entry as missing: named here for what it is.
  if (le16(zip, e.local + 8) != e.method)
    throw Error(file, "zip entry '" + show_value(e.name, 80) + "'",
                "its local header says compression method " + std::to_string(le16(zip, e.local + 8)) +
                    ", the central directory " + std::to_string(e.method) + " (a damaged archive)");
  if ((e.flags & 1u) || (e.method != 0 && e.method != 8)) return;
  const std::uint64_t data = std::uint64_t(e.local) + 30 + le16(zip, e.local + 26) + le16(zip, e.local + 28);
  if (data > zip.size()) return;
  const std::uint64_t packed = std::min<std::uint64_t>(e.packed, zip.size() - data);
  std::string lower = e.name;
  for (char& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  const bool named_xml = lower.size() >= 4 && (lower.compare(lower.size() - 4, 4, ".dae") == 0 ||
                                               lower.compare(lower.size() - 4, 4, ".xml") == 0);
  XmlDepthScan scan(kMaxXmlDepth);
  // UTF-16 text (by its byte order mark or a leading '<' code unit) is scanned by the low byte of each
  // code unit, as for a plain file. Everything before the first other byte (white space, byte order marks)
  // goes to the scan too, so lines count from the entry's start.
  enum class Start { kUndecided, kScan, kSkip } start = Start::kUndecided;
  bool encoded = false;
  int low = -1;  // UTF-16: the index (0 or 1) of a code unit's low byte; -1: bytes
  std::uint64_t raw = 0, narrowed = 0;
  std::string head, narrow;
  std::string whole;  // the scanned text, for the instance-graph check once it is known to be shallow
  auto scan_piece = [&](const char* bytes, std::size_t n) {  // false once the entry needs no more reading
    if (low >= 0) {
      narrow.clear();
      for (std::size_t k = 0; k < n; ++k)
        if ((raw + k) % 2 == std::uint64_t(low)) narrow += bytes[k];
      raw += n;
      bytes = narrow.data();
      n = narrow.size();
    }
    for (std::size_t k = 0; k < n && start == Start::kUndecided; ++k, ++narrowed) {
      const auto ch = static_cast<unsigned char>(bytes[k]);
      const bool mark = narrowed < 3 && (ch == 0xEF || ch == 0xBB || ch == 0xBF || ch == 0xFF || ch == 0xFE);
      if (!mark && !std::isspace(ch)) start = named_xml || ch == '<' ? Start::kScan : Start::kSkip;
    }
    if (start == Start::kSkip) return false;
    whole.append(bytes, n);
    return scan.feed(bytes, n);
  };
  auto take = [&](const char* bytes, std::size_t n) {
    if (encoded) return scan_piece(bytes, n);
    head.append(bytes, n);
    if (head.size() < 2) return true;
    encoded = true;
    if (head.compare(0, 2, "\xFF\xFE") == 0 || head.compare(0, 2, std::string("<\0", 2)) == 0) low = 0;
    if (head.compare(0, 2, "\xFE\xFF") == 0 || head.compare(0, 2, std::string("\0<", 2)) == 0) low = 1;
    return scan_piece(head.data(), head.size());
  };
  const char* in = zip.data() + data;
  if (e.method == 0) {
    const std::uint64_t n = std::min<std::uint64_t>(packed, e.unpacked);
    for (std::uint64_t at = 0; at < n; at += 65536)
      if (!take(in + at, static_cast<std::size_t>(std::min<std::uint64_t>(65536, n - at)))) break;
  } else {
    z_stream z{};
    if (inflateInit2(&z, -MAX_WBITS) != Z_OK) throw Error(file, e.name, "cannot start inflating the entry");
    std::vector<char> out(65536);
    std::uint64_t left_in = packed, left_out = e.unpacked;
    int status = Z_OK;
    while (status == Z_OK && left_out > 0) {
      if (z.avail_in == 0 && left_in > 0) {
        const auto chunk = static_cast<uInt>(std::min<std::uint64_t>(left_in, 1u << 30));
        z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in + (packed - left_in)));
        z.avail_in = chunk;
        left_in -= chunk;
      }
      const auto room = static_cast<uInt>(std::min<std::uint64_t>(out.size(), left_out));
      z.next_out = reinterpret_cast<Bytef*>(out.data());
      z.avail_out = room;
      status = inflate(&z, Z_NO_FLUSH);
      const std::size_t made = room - z.avail_out;
      left_out -= made;
      if (made == 0 && status == Z_OK && z.avail_in == 0 && left_in == 0) break;  // the data ends early
      if (made > 0 && !take(out.data(), made)) break;
      if (status == Z_BUF_ERROR && z.avail_in == 0 && left_in == 0) break;
    }
    inflateEnd(&z);
  }
  if (!encoded && !head.empty()) scan_piece(head.data(), head.size());
  if (start != Start::kScan) return;
  if (!scan.finish())
    throw Error(file, e.name + ", line " + std::to_string(scan.line()),
                "XML elements nest more than " + std::to_string(kMaxXmlDepth) + " levels deep");
  check_collada_instances(file + ": " + e.name, whole);  // ImportPrescan.h: cycles and node bombs
  check_collada_data(file + ": " + e.name, whole);       // ImportPrescan.h: counts, accessors, indices
}

std::uint64_t line_of(const std::string& text, std::size_t at) {
  return 1 + static_cast<std::uint64_t>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

// `mtllib` directives of an OBJ: assimp reads the named library once per directive. Every `mtllib` word
// counts, wherever it stands (a word: bounded by the file's ends, whitespace or control characters): lines
// end, and words begin, at more characters in assimp's reader (CR, form feed, NUL) than a line-based
// count would see, and a word counted too many only lowers a bound no real file comes near.
void check_mtllib(const std::string& file, const std::string& text) {
  auto separator = [&](std::size_t at) { return static_cast<unsigned char>(text[at]) <= ' '; };
  int count = 0;
  for (std::size_t at = text.find("mtllib"); at != std::string::npos; at = text.find("mtllib", at + 6)) {
    const bool word = (at == 0 || separator(at - 1)) && (at + 6 == text.size() || separator(at + 6));
    if (word && ++count > kMaxMtllib)
      throw Error(file, "line " + std::to_string(line_of(text, at)),
                  "more than " + std::to_string(kMaxMtllib) +
                      " 'mtllib' directives (each makes the reader load a material library again)");
  }
  // `o` and `usemtl` as a line's first word, a line ending at any character the reader ends one at.
  int objects = 0, switches = 0, groups = 0;
  for (std::size_t at = 0; at < text.size();) {
    while (at < text.size() && (text[at] == ' ' || text[at] == '\t')) ++at;
    std::size_t end = at;
    while (end < text.size() && !separator(end)) ++end;
    const std::string first = text.substr(at, std::min<std::size_t>(end - at, 7));
    if ((first == "o" && ++objects > kMaxObjObjects) || (first == "usemtl" && ++switches > kMaxObjObjects))
      throw Error(file, "line " + std::to_string(line_of(text, at)),
                  "more than " + std::to_string(kMaxObjObjects) + " '" + first +
                      "' directives (the reader makes and searches one " +
                      (first == "o" ? "object" : "mesh") + " per directive)");
    if (first == "g" && ++groups > kMaxObjGroups)
      throw Error(
          file, "line " + std::to_string(line_of(text, at)),
          "more than " + std::to_string(kMaxObjGroups) + " 'g' lines (the reader keeps about 1.6 KB each)");
    while (end < text.size() && text[end] != '\n' && text[end] != '\r' && text[end] != '\f' &&
           text[end] != '\0')
      ++end;
    at = end + 1;
  }
}

// What Open checks on the first opening of a file's content (throws loom::Error naming the file). A zip
// archive's unpacked size goes to `spend` before any entry is inflated; false: `spend` refused it.
bool check_content(const std::string& file, const std::function<bool(std::uint64_t)>& spend) {
  std::string text = read_input_file(file);
  if (text.compare(0, 4, "PK\x03\x04") == 0) {
    const std::vector<ZipEntry> entries = zip_entries(file, text);
    std::uint64_t unpacked = 0;
    for (const ZipEntry& e : entries) unpacked += e.unpacked;
    if (!spend(unpacked)) return false;
    for (const ZipEntry& e : entries) check_zip_entry(file, text, e);
    return true;
  }
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
    XmlDepthScan scan(kMaxXmlDepth);
    if (!scan.feed(text.data(), text.size()) || !scan.finish())
      throw Error(file, "line " + std::to_string(scan.line()),
                  "XML elements nest more than " + std::to_string(kMaxXmlDepth) + " levels deep");
    check_collada_instances(file, text);  // ImportPrescan.h
    check_collada_data(file, text);       // ImportPrescan.h
  } else {
    check_mtllib(file, text);
    check_gltf_nodes(file, text);   // ImportPrescan.h
    check_fbx_nesting(file, text);  // ImportPrescan.h
  }
  return true;
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

bool XmlDepthScan::feed(const char* data, std::size_t size) {
  for (std::size_t i = 0; i < size && !deep_;) {
    if (state_ == State::kText) {  // to the next '<' at once
      const void* found = std::memchr(data + i, '<', size - i);
      const std::size_t stop =
          found ? static_cast<std::size_t>(static_cast<const char*>(found) - data) : size;
      line_ += static_cast<std::uint64_t>(std::count(data + i, data + stop, '\n'));
      offset_ += stop - i;
      i = stop;
      if (i == size) break;
      tag_offset_ = offset_;
      tag_line_ = line_;
      open_ = "<";
      state_ = State::kOpen;
      ++i;
      ++offset_;
      continue;
    }
    const char c = data[i++];
    ++offset_;
    if (c == '\n') ++line_;
    step(c);
  }
  return !deep_;
}

void XmlDepthScan::open_element() {
  if (++depth_ > max_depth_ && !deep_) {
    deep_ = true;
    deep_offset_ = tag_offset_;
    deep_line_ = tag_line_;
  }
  state_ = State::kText;
}

void XmlDepthScan::step(char c) {
  switch (state_) {
    case State::kText:
      break;
    case State::kOpen: {
      open_ += c;
      static const std::string comment = "<!--", cdata = "<![CDATA[";
      auto start = [&](State next, const char* end) {
        state_ = next;
        end_ = end;
        tail_.clear();
      };
      if (open_ == comment) {
        start(State::kComment, "-->");
      } else if (open_ == cdata) {
        start(State::kCdata, "]]>");
      } else if (open_ == "<?") {
        start(State::kInstruction, "?>");
      } else if (open_ == "</") {
        depth_ = std::max(0L, depth_ - 1);
        start(State::kEndTag, ">");
      } else if (comment.compare(0, open_.size(), open_) == 0 || cdata.compare(0, open_.size(), open_) == 0) {
        // still undecided
      } else if (open_[1] == '!') {  // a declaration, from its '!'
        state_ = State::kDeclaration;
        brackets_ = 0;
        const std::string seen = open_.substr(1);
        for (char b : seen)
          if (state_ == State::kDeclaration) step(b);
      } else {  // a start tag
        state_ = State::kStartTag;
        quote_ = 0;
        previous_ = '<';
        step(c);
      }
      break;
    }
    case State::kComment:
    case State::kCdata:
    case State::kInstruction:
    case State::kEndTag: {
      tail_ += c;
      if (tail_.size() > 3) tail_.erase(0, tail_.size() - 3);
      const std::size_t n = std::strlen(end_);
      if (tail_.size() >= n && tail_.compare(tail_.size() - n, n, end_) == 0) state_ = State::kText;
      break;
    }
    case State::kDeclaration:
      if (c == '>' && brackets_ <= 0)
        state_ = State::kText;
      else
        brackets_ += c == '[' ? 1 : c == ']' ? -1 : 0;
      break;
    case State::kStartTag:  // to its '>' outside quoted values; "/>" closes it at once
      if (!quote_ && c == '>') {
        if (previous_ == '/')
          state_ = State::kText;
        else
          open_element();
        break;
      }
      if (quote_ ? c == quote_ : c == '"' || c == '\'') quote_ = quote_ ? 0 : c;
      previous_ = c;
      break;
  }
}

bool XmlDepthScan::finish() {
  if (state_ == State::kStartTag || (state_ == State::kOpen && open_ == "<")) open_element();
  state_ = State::kText;
  return !deep_;
}

long xml_too_deep(const std::string& text, int max_depth) {
  XmlDepthScan scan(max_depth);
  if (scan.feed(text.data(), text.size()) && scan.finish()) return -1;
  return static_cast<long>(scan.offset());
}

std::uint64_t import_source_bytes(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return 0;  // never opened: a FIFO would block
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  if (ec || size > kMaxImportBytes) return ec ? 0 : size;
  std::ifstream in(path, std::ios::binary);
  char head[4] = {};
  in.read(head, sizeof head);
  if (std::string(head, 4) == "PK\x03\x04") {  // a zip archive: what it unpacks to
    try {
      std::uint64_t unpacked = 0;
      for (const ZipEntry& e : zip_entries(path, read_input_file(path))) unpacked += e.unpacked;
      return std::max(size, unpacked);
    } catch (const Error&) {
      return size;  // the import names what is wrong with the archive
    }
  }
  // A glTF's JSON: its buffers (external .bin files or data URIs) hold the keys.
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".gltf") return size;
  const nlohmann::json doc = nlohmann::json::parse(read_input_file(path), nullptr, false);
  std::uint64_t buffers = 0;
  if (doc.is_object() && doc.contains("buffers") && doc["buffers"].is_array())
    for (const nlohmann::json& b : doc["buffers"])
      if (b.is_object() && b.contains("byteLength") && b["byteLength"].is_number_unsigned())
        buffers += std::min<std::uint64_t>(b["byteLength"].get<std::uint64_t>(), kMaxImportBytes);
  return size + buffers;
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
    if (scanned_.insert(file).second &&
        !check_content(file, [&](std::uint64_t unpacked) { return spend(file, unpacked); }))
      return nullptr;
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
  // The file itself first, with the system's reason (open_error_text): assimp asks Exists() and says only
  // "Unable to open file" for a missing file, a loop of links or a folder without access alike.
  try {
    loom::check_input_file(path);
  } catch (const Error& e) {
    const std::string text = e.what(), head = path + ": ";
    throw Error(path, "",
                "cannot read " + what + ": " +
                    (text.compare(0, head.size(), head) == 0 ? text.substr(head.size()) : text));
  }
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
