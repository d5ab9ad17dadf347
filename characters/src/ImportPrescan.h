#pragma once
// ImportPrescan: checks of a file's node graph, nesting and counts that must run before assimp reads it,
// because assimp's readers expand or recurse without bound or trust the counts a file gives: a COLLADA
// <instance_node> cycle or a chain of nodes each instancing the next twice, a COLLADA array, accessor or
// index list whose counts disagree with its data, a glTF node listed as the child of two parents, an FBX
// nested deeper than its reader's stack. Each check streams over the file's text (no document tree is
// built beyond a glTF's node list and a COLLADA file's per-id summaries) and throws loom::Error naming the
// file and the line, node or byte offset.
#include <cstdint>
#include <string>

namespace loom::characters {

// Nodes a file's node tree may expand to (instanced nodes counted once per instance): a human skeleton
// with its meshes has a few hundred; assimp holds a few hundred bytes per node.
constexpr std::uint64_t kMaxExpandedNodes = 1'000'000;
// FBX scopes (ASCII braces, binary node records) nested deeper than this are refused: twice the deepest
// skeleton (kMaxJointDepth); assimp's FBX tokenizer and parser recurse per scope.
constexpr int kMaxFbxDepth = 512;

// A COLLADA document (`text` holds <COLLADA>; other XML passes): every <node> with its id and name, its
// nested <node>s and its <instance_node url="#..."> references. Refuses a reference cycle (a node that
// instances itself, directly or through others) naming the nodes and the line, and a scene whose nodes
// expand to more than kMaxExpandedNodes (counted on the instancing graph, each node once).
void check_collada_instances(const std::string& file, const std::string& text);

// Input offsets and sets a COLLADA <input> may name, the largest accessor stride (a 4x4 matrix has 16), and
// the values, indices and per-joint lists a COLLADA document's counts may imply per byte of the file.
constexpr std::uint64_t kMaxInputOffset = 255;
constexpr std::uint64_t kMaxInputSet = 255;
constexpr std::uint64_t kMaxAccessorStride = 1024;
constexpr std::uint64_t kColladaValuesPerByte = 4;

// A COLLADA document's data, as assimp's COLLADA reader would trust it (`text` holds <COLLADA>; other XML
// passes). Refused, naming the line and the element or attribute:
// - a <float_array>, <int_array>, <Name_array>, <IDREF_array> or <bool_array> whose count is missing, not a
//   whole number, or not the number of values it holds, or with a value that is not of its type (floats
//   finite);
// - an <accessor> whose source is no array of the file, whose count, stride (1 to kMaxAccessorStride) or
//   offset is not a whole number, that reads past its array (offset + count * stride) or whose <param>s
//   read more values than its stride;
// - an <input> offset or set past kMaxInputOffset / kMaxInputSet;
// - a primitive (<triangles>, <polylist>, ...) whose <vcount> and <p> tokens are not whole numbers or do
//   not match its count and its inputs (max offset + 1 indices per vertex), that has indices but no VERTEX
//   input of its mesh's <vertices> (with a POSITION), or an index past the accessor read at its offset;
// - a <skin> whose bind_shape_matrix is not 16 numbers, whose inverse bind matrices do not cover its
//   joints, whose <vertex_weights> count, <vcount> and <v> disagree, index a joint or weight that is not
//   there or cover fewer vertices than the skinned mesh indexes;
// - an animation <channel> whose OUTPUT values per key overrun the transform it targets, or whose ANGLE
//   keys turn through more 90-degree steps (assimp samples each) than the bound below;
// - a document whose counts imply more than kColladaValuesPerByte values per byte (plus 2^20).
void check_collada_data(const std::string& file, const std::string& text);

// A glTF's JSON (text starting with '{') or a binary glTF (.glb, magic "glTF"): every node has at most one
// parent, no node is its own ancestor, and the scenes' root lists expand to at most kMaxExpandedNodes.
// Every buffer view lies inside its buffer, every accessor (and its sparse indices and values) inside its
// view, a buffer inside its data URI or the BIN chunk, with whole-number fields below 2^53 and valid
// component types (glTF 2.0, section 5), and an animation channel's sampler reads key times from a SCALAR
// accessor and one value per key (three for CUBICSPLINE) of its path's type: refused naming the field
// (`accessors[1].sparse.indices.byteOffset`, `animations[0].samplers[0].output`).
// A document that is not JSON, or gives a key twice in one object, is refused.
void check_gltf_nodes(const std::string& file, const std::string& text);
// JSON nesting of a glTF (its `extras` may nest; every reader's work and stack grow with the depth).
constexpr int kMaxGltfJsonDepth = 1000;

// An FBX: binary (magic "Kaydara FBX Binary") by its node records (end offset, property count and length,
// name; Blender's and assimp's reading of the format), refusing records out of range by byte offset and
// nesting past kMaxFbxDepth; ASCII (a file named *.fbx in any case, or with "FBX" in its first 200 bytes)
// by its braces outside strings and ';' comments, refused past kMaxFbxDepth by line. Other text passes.
void check_fbx_nesting(const std::string& file, const std::string& text);

}  // namespace loom::characters
