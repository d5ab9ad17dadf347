#pragma once
// AssimpInput: the one way loom::characters hands a file to assimp. Every file assimp opens for reading
// (the file itself and whatever it references: a glTF's external .bin buffers, an OBJ's .mtl libraries, a
// Collada's or FBX's linked files) goes through loom::check_input_file first (a regular file of at most
// 1 GiB: no folder, device such as /dev/zero, or pipe) and is recorded, so a checkpoint can hash every file
// a run depended on. One import reads at most kMaxImportBytes in all: the bytes read from every file it
// opens, plus what each zip archive (a .zae) it opens unpacks to by its directory, so a file referenced
// many times or a small archive of a huge file cannot exceed the bound one input file has. Before assimp
// sees a file, text that nests XML elements deeper than kMaxXmlDepth (assimp's readers recurse per level)
// and an OBJ naming more than kMaxMtllib material libraries, or more than kMaxObjObjects objects or
// material switches or kMaxObjGroups group lines, are refused by file and line.
#include <assimp/DefaultIOSystem.h>
#include <assimp/scene.h>

#include <assimp/IOStream.hpp>
#include <assimp/Importer.hpp>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace loom::characters {

constexpr std::uint64_t kMaxImportBytes = std::uint64_t(1) << 30;  // bytes one import reads in all
constexpr int kMaxXmlDepth = 512;  // XML element levels: twice the deepest skeleton (kMaxJointDepth)
constexpr int kMaxMtllib = 16;     // `mtllib` directives in one OBJ
// `o` and `usemtl` directives in one OBJ: assimp's reader makes an object or a mesh for each and searches
// them by name (65536 `o` lines took 15 s, 65536 `usemtl` 11 s and 2.2 GB for a 1 MB file).
constexpr int kMaxObjObjects = 1024;
// `g` lines in one OBJ: each costs the reader about 1.6 KB (a million took 1.68 GB for a 12 MB file).
constexpr int kMaxObjGroups = 16384;
// Deepest node nesting a file may have (a human skeleton has under 30 levels): Loom's readers and assimp's
// post-processing recurse per level.
constexpr int kMaxJointDepth = 256;

class RecordingIOSystem : public Assimp::DefaultIOSystem {
 public:
  Assimp::IOStream* Open(const char* file, const char* mode = "rb") override;
  // By the file's status, never by opening it (assimp's own Exists opens the file: a pipe would block).
  bool Exists(const char* file) const override;
  // Files opened for reading, in first-open order, each once (as assimp named them).
  const std::vector<std::string>& files() const { return files_; }
  // The first file refused ("" if none) and the full message (naming the file).
  const std::string& refused() const { return refused_; }
  const std::string& refusal() const { return refusal_; }
  // Counts `bytes` towards kMaxImportBytes; false (and the refusal recorded against `file`) past it.
  bool spend(const std::string& file, std::uint64_t bytes);
  void refuse(const std::string& file, const std::string& message);

 private:
  std::vector<std::string> files_;
  std::set<std::string> scanned_;  // files whose content was checked (once each)
  std::uint64_t spent_ = 0;
  std::string refused_, refusal_;
};

// What an import of `path` reads before it builds anything, in bytes, found without reading it through
// assimp: the file's size, a zip archive's (a .zae's) unpacked size by its directory, a glTF's JSON plus the
// byteLength of its buffers. 0 for a file that cannot be read (the import names it).
std::uint64_t import_source_bytes(const std::string& path);

// Reads `path` with `importer` (post-processing `flags`) through a RecordingIOSystem, on a thread with a
// 256 MB stack (assimp's readers recurse per nesting level of formats Loom does not pre-scan), and appends
// every file read to `files`. Throws loom::Error naming `path` (and the referenced file it refused, if any)
// when assimp cannot read it, when it breaks the bounds above, or when the scene assimp returns is not
// whole (a null node, mesh, bone, animation or channel, an index out of range, nodes nested deeper than
// kMaxJointDepth); `what` names the kind of content ("motion", "the mesh") in the message.
const aiScene* read_with_assimp(Assimp::Importer& importer, const std::string& path, unsigned flags,
                                const std::string& what, std::vector<std::string>& files);

// The element-depth check of XML text fed in pieces of any size (an archive entry as it is inflated):
// comments, CDATA sections, processing instructions, declarations and quoted attribute values are skipped;
// a start tag the text ends inside counts as one level.
class XmlDepthScan {
 public:
  explicit XmlDepthScan(int max_depth) : max_depth_(max_depth) {}
  // The next `size` bytes of the text; false once an element nests deeper than max_depth.
  bool feed(const char* data, std::size_t size);
  // The end of the text; false if an element nests deeper than max_depth.
  bool finish();
  bool too_deep() const { return deep_; }
  // Of the first element nested too deep (its '<'): the byte index in the text and its 1-based line.
  std::uint64_t offset() const { return deep_offset_; }
  std::uint64_t line() const { return deep_line_; }

 private:
  enum class State { kText, kOpen, kComment, kCdata, kInstruction, kDeclaration, kEndTag, kStartTag };
  void step(char c);
  void open_element();

  int max_depth_;
  State state_ = State::kText;
  long depth_ = 0;
  std::uint64_t offset_ = 0, line_ = 1;          // position of the next byte
  std::uint64_t tag_offset_ = 0, tag_line_ = 1;  // of the '<' that opened the current markup
  std::string open_;                             // the markup's first bytes while its kind is undecided
  std::string tail_;                             // its last bytes, to find its end ("-->", "]]>", "?>")
  const char* end_ = "";
  int brackets_ = 0;  // a declaration's internal subset: '[' minus ']'
  char quote_ = 0;    // a start tag's open attribute quote
  char previous_ = 0;
  bool deep_ = false;
  std::uint64_t deep_offset_ = 0, deep_line_ = 0;
};

// The index of the first XML element nested deeper than `max_depth` in `text` (-1 if none), as XmlDepthScan
// finds it.
long xml_too_deep(const std::string& text, int max_depth);

}  // namespace loom::characters
