#include "ImportPrescan.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/InputFile.h"

namespace loom::characters {

namespace {

std::string line_at(const std::string& text, std::size_t at) {
  at = std::min(at, text.size());
  return "line " +
         std::to_string(1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

std::uint64_t saturating_add(std::uint64_t a, std::uint64_t b) {
  constexpr std::uint64_t kCap = kMaxExpandedNodes + 1;
  return std::min(kCap, std::min(a, kCap) + std::min(b, kCap));
}

// ---- COLLADA: the <node> / <instance_node> graph ----

struct DaeNode {
  int parent;    // enclosing <node> (-1: none)
  bool library;  // inside <library_nodes>: instanced, not a scene root
  std::size_t at;
  std::string id, name;
};
struct DaeRef {
  int from;  // the <node> holding the <instance_node>
  std::size_t at;
  std::string target;  // the url without its leading '#'
};

// The attribute `key` of the start tag text[begin, end) into `out`; false if absent. Values in ' or " quotes.
bool find_attribute(const std::string& text, std::size_t begin, std::size_t end, const char* key,
                    std::string& out) {
  const std::size_t key_size = std::strlen(key);
  std::size_t at = begin;
  while (at < end && !std::isspace(static_cast<unsigned char>(text[at])) && text[at] != '/') ++at;  // name
  while (at < end) {
    while (at < end && (std::isspace(static_cast<unsigned char>(text[at])) || text[at] == '/')) ++at;
    const std::size_t name = at;
    while (at < end && text[at] != '=' && !std::isspace(static_cast<unsigned char>(text[at]))) ++at;
    const std::size_t name_end = at;
    while (at < end && std::isspace(static_cast<unsigned char>(text[at]))) ++at;
    if (at >= end || text[at] != '=') continue;
    ++at;
    while (at < end && std::isspace(static_cast<unsigned char>(text[at]))) ++at;
    if (at >= end || (text[at] != '"' && text[at] != '\'')) return false;
    const char quote = text[at++];
    const std::size_t value = at;
    while (at < end && text[at] != quote) ++at;
    if (name_end - name == key_size && text.compare(name, key_size, key) == 0) {
      out = text.substr(value, at - value);
      return true;
    }
    ++at;
  }
  return false;
}

// The attribute `key` of the start tag text[begin, end) ("" if absent).
std::string attribute(const std::string& text, std::size_t begin, std::size_t end, const char* key) {
  std::string value;
  return find_attribute(text, begin, end, key, value) ? value : std::string();
}

// A markup declaration other than a comment or CDATA (<!DOCTYPE, <!ENTITY, ...): COLLADA is defined by an
// XML Schema and has none, and a document type's internal subset (quoted brackets, entities) would hide the
// rest of the file from these scans while the XML reader behind assimp reads it. Refused by line.
[[noreturn]] void refuse_declaration(const std::string& file, const std::string& text, std::size_t at) {
  std::size_t end = at + 2;
  while (end < text.size() && end < at + 12 && std::isalpha(static_cast<unsigned char>(text[end]))) ++end;
  throw Error(file, line_at(text, at),
              "'" + text.substr(at, end - at) +
                  "': a markup declaration (a document type or an entity); COLLADA files have none and Loom "
                  "reads none");
}

std::string dae_label(const DaeNode& n) {
  return "'" + (n.id.empty() ? n.name.empty() ? std::string("(unnamed)") : n.name : n.id) + "'";
}

}  // namespace

void check_collada_instances(const std::string& file, const std::string& text) {
  if (text.find("<COLLADA") == std::string::npos) return;
  std::vector<DaeNode> nodes;
  std::vector<DaeRef> refs;
  std::vector<char> open;  // kinds of the open elements: 'n' <node>, 'l' <library_nodes>, 'o' other
  std::vector<int> node_stack;
  int libraries = 0;
  const std::size_t n = text.size();
  auto skip_past = [&](std::size_t from, const char* end) {
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
    } else if (text.compare(at, 2, "<!") == 0) {
      refuse_declaration(file, text, at);
    } else if (text.compare(at, 2, "</") == 0) {
      if (!open.empty()) {
        if (open.back() == 'n' && !node_stack.empty()) node_stack.pop_back();
        if (open.back() == 'l') --libraries;
        open.pop_back();
      }
      at = skip_past(at + 2, ">");
    } else {
      const std::size_t start = at;
      char quote = 0;
      for (++at; at < n && (quote || text[at] != '>'); ++at)
        if (quote ? text[at] == quote : text[at] == '"' || text[at] == '\'') quote = quote ? 0 : text[at];
      const bool empty = at < n && text[at - 1] == '/';
      std::size_t name_end = start + 1;
      while (name_end < at && !std::isspace(static_cast<unsigned char>(text[name_end])) &&
             text[name_end] != '/')
        ++name_end;
      const std::string element = text.substr(start + 1, name_end - start - 1);
      char kind = 'o';
      if (element == "node") {
        if (nodes.size() >= kMaxExpandedNodes)
          throw Error(file, line_at(text, start),
                      "more than " + std::to_string(kMaxExpandedNodes) + " <node> elements");
        nodes.push_back({node_stack.empty() ? -1 : node_stack.back(), libraries > 0, start,
                         attribute(text, start + 1, at, "id"), attribute(text, start + 1, at, "name")});
        kind = 'n';
        if (!empty) node_stack.push_back(static_cast<int>(nodes.size()) - 1);
      } else if (element == "instance_node" && !node_stack.empty()) {
        if (refs.size() >= kMaxExpandedNodes)
          throw Error(file, line_at(text, start),
                      "more than " + std::to_string(kMaxExpandedNodes) + " <instance_node> elements");
        std::string url = attribute(text, start + 1, at, "url");
        if (!url.empty() && url[0] == '#') url.erase(0, 1);
        refs.push_back({node_stack.back(), start, url});
      } else if (element == "library_nodes") {
        kind = 'l';
        if (!empty) ++libraries;
      }
      if (!empty) open.push_back(kind);
      ++at;
    }
  }
  if (refs.empty()) return;  // a plain tree: its size is bounded by the file's

  // An <instance_node> resolves to the nodes with that id, or (assimp's fallback) with that name.
  std::unordered_map<std::string, std::vector<int>> by_id, by_name;
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    if (!nodes[k].id.empty()) by_id[nodes[k].id].push_back(static_cast<int>(k));
    if (!nodes[k].name.empty()) by_name[nodes[k].name].push_back(static_cast<int>(k));
  }
  std::vector<std::vector<std::pair<int, int>>> out(nodes.size());  // (node, reference index; -1: nested)
  for (std::size_t k = 0; k < nodes.size(); ++k)
    if (nodes[k].parent >= 0) out[static_cast<std::size_t>(nodes[k].parent)].push_back({int(k), -1});
  for (std::size_t r = 0; r < refs.size(); ++r) {
    const std::vector<int>* targets = nullptr;
    if (const auto id = by_id.find(refs[r].target); id != by_id.end()) targets = &id->second;
    if (const auto nm = by_name.find(refs[r].target); !targets && nm != by_name.end()) targets = &nm->second;
    if (!targets) continue;  // unresolved: assimp skips it
    for (int t : *targets) out[static_cast<std::size_t>(refs[r].from)].push_back({t, int(r)});
  }

  // Depth-first over the graph (an explicit stack): a reference to a node still open is a cycle; a
  // finished node's expanded size is 1 + its successors' sizes, capped past kMaxExpandedNodes.
  std::vector<char> state(nodes.size(), 0);  // 0 unseen, 1 open, 2 done
  std::vector<std::uint64_t> size(nodes.size(), 0);
  struct Frame {
    int node;
    std::size_t next;
  };
  std::vector<Frame> stack;
  for (std::size_t s = 0; s < nodes.size(); ++s) {
    if (state[s] != 0) continue;
    state[s] = 1;
    stack.push_back({int(s), 0});
    while (!stack.empty()) {
      const int v = stack.back().node;
      const auto& edges = out[static_cast<std::size_t>(v)];
      if (stack.back().next < edges.size()) {
        const auto [t, ref] = edges[stack.back().next++];
        if (state[static_cast<std::size_t>(t)] == 1) {
          std::size_t first = stack.size();
          while (first > 0 && stack[first - 1].node != t) --first;
          std::string cycle;
          for (std::size_t k = first - 1; k < stack.size(); ++k) {
            if (k - (first - 1) == 8 && stack.size() - k > 2) {
              cycle += "... -> ";
              k = stack.size() - 2;
              continue;
            }
            cycle += dae_label(nodes[static_cast<std::size_t>(stack[k].node)]) + " -> ";
          }
          cycle += dae_label(nodes[static_cast<std::size_t>(t)]);
          const DaeRef& r = refs[static_cast<std::size_t>(ref)];
          throw Error(file, line_at(text, r.at),
                      "node " + dae_label(nodes[static_cast<std::size_t>(v)]) + ": <instance_node url=\"#" +
                          r.target + "\"> makes an instance_node cycle (" + cycle +
                          "): the node would contain itself");
        }
        if (state[static_cast<std::size_t>(t)] == 0) {
          state[static_cast<std::size_t>(t)] = 1;
          stack.push_back({t, 0});
        }
        continue;
      }
      std::uint64_t total = 1;
      for (const auto& [t, ref] : edges) total = saturating_add(total, size[static_cast<std::size_t>(t)]);
      size[static_cast<std::size_t>(v)] = total;
      state[static_cast<std::size_t>(v)] = 2;
      stack.pop_back();
    }
  }
  std::uint64_t scene = 0;
  int largest = -1;
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    if (nodes[k].parent >= 0 || nodes[k].library) continue;
    scene = saturating_add(scene, size[k]);
    if (largest < 0 || size[k] > size[static_cast<std::size_t>(largest)]) largest = int(k);
  }
  if (scene > kMaxExpandedNodes) {
    const DaeNode& root = nodes[static_cast<std::size_t>(largest)];
    throw Error(file, line_at(text, root.at),
                "node " + dae_label(root) +
                    ": with its <instance_node> copies the scene expands to more than " +
                    std::to_string(kMaxExpandedNodes) + " nodes");
  }
}

// ---- COLLADA: data arrays, accessors, index lists and skins ----

namespace {

bool xml_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

// A whole number of digits only (no sign), at most 2^63; false otherwise.
bool parse_whole(const char* b, const char* e, std::uint64_t& out) {
  if (b == e) return false;
  std::uint64_t v = 0;
  for (const char* c = b; c < e; ++c) {
    if (*c < '0' || *c > '9') return false;
    if (v > (std::uint64_t(1) << 63) / 10) return false;
    v = v * 10 + std::uint64_t(*c - '0');
  }
  out = v;
  return true;
}

// A finite number as assimp's reader takes it: an optional sign, digits with a '.' or (as written under some
// locales) a ',' before the fraction, an optional exponent.
bool parse_finite(const char* b, const char* e, double* value = nullptr) {
  if (b < e && *b == '+') ++b;
  if (b == e || e - b > 256) return false;
  char copy[257];
  std::size_t size = 0;
  for (const char* c = b; c < e; ++c)
    copy[size++] = *c == ',' && c + 1 < e && c[1] >= '0' && c[1] <= '9' ? '.' : *c;
  double v = 0;
  const auto r = std::from_chars(copy, copy + size, v);
  if (value) *value = v;
  return r.ec == std::errc() && r.ptr == copy + size && std::isfinite(v);
}

bool parse_int(const char* b, const char* e) {
  if (b < e && (*b == '-' || *b == '+')) ++b;
  std::uint64_t v = 0;
  return parse_whole(b, e, v);
}

struct DaeInput {
  std::string semantic, source;  // source without its '#'
  std::uint64_t offset = 0;
  std::size_t at = 0;
};
struct DaeArrays {  // the arrays of one id (ids should be unique; each duplicate is checked)
  std::uint64_t min_count = ~std::uint64_t(0), max_count = 0;
  bool names = false, numbers = false;  // <Name_array>/<IDREF_array>; the others
  std::size_t text = 0;                 // where the last one's values start (assimp keeps the last)
};
struct DaeAccessor {
  std::string array;  // the source attribute without its '#'
  std::uint64_t count = 0, stride = 1, offset = 0, params = 0, size = 0;  // size: assimp's (float4x4 16)
  std::size_t at = 0;
};
struct DaeMesh {
  std::string geometry;  // the id of its <geometry>
  int vertices = -1;     // its <vertices>
  bool indexed = false;  // a primitive indexed VERTEX
  std::uint64_t max_vertex = 0, primitives = 0;
};
struct DaeVertices {
  std::string id;
  std::vector<DaeInput> inputs;
};
struct DaeUse {  // an index list's largest index read through one input (checked once the file is read)
  DaeInput input;
  int vertices;  // for VERTEX: the mesh's <vertices>
  std::uint64_t max;
  std::size_t at;  // the index list
};
struct DaeSkin {
  std::string mesh;
  std::size_t at = 0;
  std::vector<DaeInput> joints, weights;
  bool has_weights = false;
  std::uint64_t count = 0, vsum = 0, vcount_tokens = 0;
  std::size_t weights_at = 0, vcount_at = 0, v_at = 0;
  bool vcount = false, v = false;
  std::vector<std::uint64_t> max_v;  // per offset
};
struct DaeChannel {
  std::string sampler, target;
  std::size_t at;
};

// The input semantics assimp's COLLADA reader keeps (the others are dropped and take no index slot).
bool known_semantic(const std::string& s) {
  return s == "POSITION" || s == "VERTEX" || s == "NORMAL" || s == "TEXCOORD" || s == "COLOR" ||
         s == "BINORMAL" || s == "TEXBINORMAL" || s == "TANGENT" || s == "TEXTANGENT";
}

// assimp's sub-element of an animation channel target ("node/transform.X", "node/matrix(1)(2)").
std::uint64_t target_sub_element(const std::string& target) {
  const std::size_t slash = target.find('/');
  if (slash == std::string::npos) return 0;
  std::uint64_t sub = 0;
  const std::size_t dot = target.find('.');
  if (dot != std::string::npos) {
    const std::string s = target.substr(dot + 1);
    sub = s == "ANGLE" ? 3 : s == "Y" ? 1 : s == "Z" ? 2 : 0;
  }
  const std::size_t bracket = target.find('(');
  if (bracket != std::string::npos) {
    const std::string s = target.substr(bracket);
    if (s.size() == 6 && s[0] == '(' && s[2] == ')' && s[3] == '(' && s[5] == ')' && s[1] >= '0' &&
        s[1] <= '3' && s[4] >= '0' && s[4] <= '3')
      sub = std::uint64_t(s[1] - '0') + 4 * std::uint64_t(s[4] - '0');
  }
  return sub;
}

}  // namespace

void check_collada_data(const std::string& file, const std::string& text) {
  if (text.find("<COLLADA") == std::string::npos) return;
  const std::size_t n = text.size();
  auto refuse = [&](std::size_t at, const std::string& problem) {
    throw Error(file, line_at(text, at), problem);
  };
  std::unordered_map<std::string, DaeArrays> arrays;
  std::unordered_map<std::string, std::vector<DaeAccessor>> accessors;  // by the enclosing <source>'s id
  std::vector<DaeMesh> meshes;
  std::vector<DaeVertices> vertices;
  std::vector<DaeUse> uses;
  std::vector<DaeSkin> skins;
  std::unordered_map<std::string, std::vector<DaeInput>> samplers;
  std::vector<DaeChannel> channels;
  std::uint64_t implied = 0;  // numbers, indices and per-joint lists the counts imply

  // The open elements: name, and for <source>, <geometry>, <mesh>, <vertices>, <skin>, <sampler> and the
  // primitives the index of what they fill.
  std::vector<std::string> open;
  std::vector<std::string> source_ids, geometry_ids;
  std::vector<DaeAccessor> accessor_stack;
  // The primitive element being read.
  struct Primitive {
    std::string kind;
    std::uint64_t count = 0;
    std::size_t at = 0;
    int mesh = -1;
    std::vector<DaeInput> inputs;
    bool read_indices = false, vcount = false;
    std::uint64_t lists = 0, vsum = 0, slots = 1;
    std::vector<std::uint64_t> max;  // per offset
    std::vector<bool> seen;
  } prim;
  bool in_prim = false;
  DaeSkin skin;
  bool in_skin = false;
  std::string sampler_id;
  std::vector<DaeInput> sampler_inputs;

  auto nearest = [&](const char* name) {
    for (std::size_t k = open.size(); k-- > 0;)
      if (open[k] == name) return int(k);
    return -1;
  };
  auto parent_is = [&](const char* name) { return !open.empty() && open.back() == name; };
  auto whole_attr = [&](std::size_t start, std::size_t end, const std::string& element, const char* key,
                        std::uint64_t fallback, std::uint64_t max, bool required) {
    std::string value;
    if (!find_attribute(text, start + 1, end, key, value)) {
      if (required) refuse(start, "<" + element + ">: the " + key + " attribute is missing");
      return fallback;
    }
    std::uint64_t v = 0;
    std::size_t b = 0, e = value.size();
    while (b < e && xml_space(value[b])) ++b;
    while (e > b && xml_space(value[e - 1])) --e;
    if (!parse_whole(value.data() + b, value.data() + e, v) || v > max)
      refuse(start, "<" + element + "> " + key + "=\"" + value.substr(0, 40) +
                        "\": not a whole number from 0 to " + std::to_string(max));
    return v;
  };
  // The text of a data element from `begin` (past its start tag) to its end tag; tokens go to `each`.
  auto tokens = [&](std::size_t begin, const std::string& element, std::size_t start,
                    const std::function<void(const char*, const char*)>& each) {
    const std::size_t end = std::min(n, text.find('<', begin));
    const std::string close = "</" + element;
    if (end >= n || text.compare(end, close.size(), close) != 0 ||
        (end + close.size() < n && text[end + close.size()] != '>' && !xml_space(text[end + close.size()])))
      refuse(start,
             "<" + element + "> holds markup or is not closed (the reader takes only plain text here)");
    for (std::size_t at = begin; at < end;) {
      while (at < end && xml_space(text[at])) ++at;
      const std::size_t b = at;
      while (at < end && !xml_space(text[at])) ++at;
      if (at > b) each(text.data() + b, text.data() + at);
    }
    const std::size_t gt = text.find('>', end);
    return gt == std::string::npos ? n : gt + 1;
  };
  auto token_at = [&](const char* p) { return std::size_t(p - text.data()); };
  auto bad_token = [&](const char* b, const char* e, const std::string& element, const std::string& want) {
    refuse(token_at(b), "<" + element + ">: '" +
                            std::string(b, std::min<std::size_t>(40, std::size_t(e - b))) + "' is not " +
                            want);
  };
  // An index list (<p>, <v>) read through `inputs` with `slots` indices per vertex: every token a whole
  // number, the largest per slot kept; returns the number of tokens.
  auto index_list = [&](std::size_t begin, const std::string& element, std::size_t start, std::uint64_t slots,
                        std::vector<std::uint64_t>& max, std::vector<bool>& seen, std::size_t& end) {
    std::uint64_t count = 0;
    if (max.size() < slots) {
      max.resize(slots, 0);
      seen.resize(slots, false);
    }
    end = tokens(begin, element, start, [&](const char* b, const char* e) {
      std::uint64_t v = 0;
      if (!parse_whole(b, e, v) || v > 0xffffffffu)
        bad_token(b, e, element, "an index (a whole number >= 0)");
      const std::size_t slot = std::size_t(count % slots);
      if (!seen[slot] || v > max[slot]) max[slot] = v;
      seen[slot] = true;
      ++count;
    });
    return count;
  };

  for (std::size_t at = text.find('<'); at < n; at = text.find('<', at)) {
    if (text.compare(at, 4, "<!--") == 0) {
      const std::size_t e = text.find("-->", at + 4);
      at = e == std::string::npos ? n : e + 3;
      continue;
    }
    if (text.compare(at, 9, "<![CDATA[") == 0) {
      const std::size_t e = text.find("]]>", at + 9);
      at = e == std::string::npos ? n : e + 3;
      continue;
    }
    if (text.compare(at, 2, "<?") == 0) {
      const std::size_t e = text.find("?>", at + 2);
      at = e == std::string::npos ? n : e + 2;
      continue;
    }
    if (text.compare(at, 2, "<!") == 0) refuse_declaration(file, text, at);
    if (text.compare(at, 2, "</") == 0) {
      at = std::min(n, text.find('>', at));
      if (at < n) ++at;
      if (open.empty()) continue;
      const std::string closing = open.back();
      open.pop_back();
      // The element ends: what it gathered is checked or filed.
      if (closing == "source" && !source_ids.empty()) {
        source_ids.pop_back();
      } else if (closing == "geometry" && !geometry_ids.empty()) {
        geometry_ids.pop_back();
      } else if (closing == "accessor" && !accessor_stack.empty()) {
        const DaeAccessor a = accessor_stack.back();
        accessor_stack.pop_back();
        if (std::max(a.params, a.size) > a.stride)
          refuse(a.at, "<accessor source=\"#" + a.array + "\">: its <param>s read " +
                           std::to_string(std::max(a.params, a.size)) + " values per element but stride is " +
                           std::to_string(a.stride));
        if (!source_ids.empty() && !source_ids.back().empty()) accessors[source_ids.back()].push_back(a);
      } else if (closing == "sampler") {
        if (!sampler_id.empty()) samplers[sampler_id] = sampler_inputs;
        sampler_id.clear();
        sampler_inputs.clear();
      } else if (in_prim && (closing == prim.kind)) {
        in_prim = false;
        const Primitive& p = prim;
        const bool strips =
            p.kind == "polygons" || p.kind == "trifans" || p.kind == "tristrips" || p.kind == "linestrips";
        if (strips && p.count != p.lists)
          refuse(p.at, "<" + p.kind + " count=\"" + std::to_string(p.count) + "\"> holds " +
                           std::to_string(p.lists) + " <p> lists (count is the number of lists)");
        if (p.kind == "polylist" && p.count > 0 && !p.vcount)
          refuse(p.at, "<polylist count=\"" + std::to_string(p.count) + "\"> has no <vcount>");
        if (p.read_indices) {
          DaeMesh& mesh = meshes[std::size_t(p.mesh)];
          ++mesh.primitives;
          bool vertex = false;
          for (const DaeInput& in : p.inputs) {
            if (!known_semantic(in.semantic)) continue;
            if (!p.seen[std::size_t(in.offset)]) continue;
            const std::uint64_t max = p.max[std::size_t(in.offset)];
            if (in.semantic == "VERTEX") {
              vertex = true;
              if (mesh.vertices < 0 || vertices[std::size_t(mesh.vertices)].id != in.source)
                refuse(in.at, "<input semantic=\"VERTEX\" source=\"#" + in.source +
                                  "\">: not the <vertices> of its <mesh> (declared before the primitives)");
              mesh.max_vertex = mesh.indexed ? std::max(mesh.max_vertex, max) : max;
              mesh.indexed = true;
            }
            uses.push_back({in, in.semantic == "VERTEX" ? mesh.vertices : -1, max, p.at});
          }
          if (!vertex) refuse(p.at, "<" + p.kind + "> has indices but no <input semantic=\"VERTEX\">");
        }
      } else if (in_skin && closing == "skin") {
        in_skin = false;
        skins.push_back(skin);
      }
      continue;
    }
    // A start tag.
    const std::size_t start = at;
    char quote = 0;
    for (++at; at < n && (quote || text[at] != '>'); ++at)
      if (quote ? text[at] == quote : text[at] == '"' || text[at] == '\'') quote = quote ? 0 : text[at];
    const std::size_t tag_end = at;
    const bool empty = at < n && text[at - 1] == '/';
    at = std::min(n, at + 1);
    std::size_t name_end = start + 1;
    while (name_end < tag_end && !xml_space(text[name_end]) && text[name_end] != '/') ++name_end;
    const std::string element = text.substr(start + 1, name_end - start - 1);
    auto attr = [&](const char* key) { return attribute(text, start + 1, tag_end, key); };
    auto reference = [&](const char* key) {
      std::string v = attr(key);
      if (!v.empty() && v[0] == '#') v.erase(0, 1);
      return v;
    };

    if (element == "float_array" || element == "int_array" || element == "Name_array" ||
        element == "IDREF_array" || element == "bool_array") {
      const char kind = element[0] == 'f'   ? 'f'
                        : element[0] == 'i' ? 'i'
                        : element[0] == 'N' ? 'n'
                        : element[0] == 'I' ? 'r'
                                            : 'b';
      const std::uint64_t count = whole_attr(start, tag_end, element, "count", 0, 0xffffffffu, true);
      std::uint64_t tokens_seen = 0;
      arrays[attr("id")].text = at;
      if (!empty)
        at = tokens(at, element, start, [&](const char* b, const char* e) {
          ++tokens_seen;
          if (kind == 'f' && !parse_finite(b, e)) bad_token(b, e, element, "a finite number");
          if (kind == 'i' && !parse_int(b, e)) bad_token(b, e, element, "a whole number");
          if (kind == 'b' && !(std::string(b, e) == "true" || std::string(b, e) == "false" ||
                               std::string(b, e) == "1" || std::string(b, e) == "0"))
            bad_token(b, e, element, "true or false");
        });
      if (tokens_seen != count)
        refuse(start, "<" + element + " id=\"" + attr("id") + "\" count=\"" + std::to_string(count) +
                          "\"> holds " + std::to_string(tokens_seen) + " values");
      DaeArrays& same = arrays[attr("id")];
      same.min_count = std::min(same.min_count, count);
      same.max_count = std::max(same.max_count, count);
      (kind == 'n' || kind == 'r' ? same.names : same.numbers) = true;
      implied += count;
      continue;  // its end tag is read: it is not pushed
    }
    if (element == "source") {
      source_ids.push_back(attr("id"));
    } else if (element == "geometry") {
      geometry_ids.push_back(attr("id"));
    } else if (element == "mesh") {
      meshes.push_back({geometry_ids.empty() ? std::string() : geometry_ids.back(), -1, false, 0, 0});
    } else if (element == "accessor") {
      DaeAccessor a;
      a.at = start;
      a.array = attr("source");
      if (a.array.empty() || a.array[0] != '#')
        refuse(start, "<accessor source=\"" + a.array + "\">: not a reference to an array in the file (#id)");
      a.array.erase(0, 1);
      a.count = whole_attr(start, tag_end, element, "count", 0, 0xffffffffu, true);
      a.stride = whole_attr(start, tag_end, element, "stride", 1, kMaxAccessorStride, false);
      a.offset = whole_attr(start, tag_end, element, "offset", 0, 0xffffffffu, false);
      if (a.stride < 1) refuse(start, "<accessor> stride=\"0\": the stride is at least 1");
      if (!empty) {
        accessor_stack.push_back(a);
      } else if (!source_ids.empty() && !source_ids.back().empty()) {
        accessors[source_ids.back()].push_back(a);
      }
    } else if (element == "param" && parent_is("accessor") && !accessor_stack.empty()) {
      DaeAccessor& a = accessor_stack.back();
      ++a.params;
      std::string type;
      if (find_attribute(text, start + 1, tag_end, "type", type)) a.size += type == "float4x4" ? 16 : 1;
    } else if (element == "vertices" && nearest("mesh") >= 0 && !meshes.empty()) {
      meshes.back().vertices = int(vertices.size());
      vertices.push_back({attr("id"), {}});
    } else if ((element == "triangles" || element == "lines" || element == "linestrips" ||
                element == "polygons" || element == "polylist" || element == "trifans" ||
                element == "tristrips") &&
               nearest("mesh") >= 0 && !meshes.empty() && !empty) {
      prim = Primitive();
      prim.kind = element;
      prim.at = start;
      prim.mesh = int(meshes.size()) - 1;
      prim.count = whole_attr(start, tag_end, element, "count", 0, 0xffffffffu, false);
      in_prim = true;
    } else if (element == "input") {
      DaeInput in;
      in.semantic = attr("semantic");
      in.source = reference("source");
      in.at = start;
      in.offset = whole_attr(start, tag_end, element, "offset", 0, kMaxInputOffset, false);
      whole_attr(start, tag_end, element, "set", 0, kMaxInputSet, false);
      if (parent_is("vertices") && !vertices.empty()) {
        vertices.back().inputs.push_back(in);
      } else if (in_prim && parent_is(prim.kind.c_str())) {
        if (prim.read_indices || prim.vcount)
          refuse(start, "<input> after the index lists of its <" + prim.kind + ">");
        prim.inputs.push_back(in);
        if (known_semantic(in.semantic)) prim.slots = std::max(prim.slots, in.offset + 1);
      } else if (in_skin && parent_is("joints")) {
        skin.joints.push_back(in);
      } else if (in_skin && parent_is("vertex_weights")) {
        if (skin.vcount || skin.v) refuse(start, "<input> after the <vcount> or <v> of its <vertex_weights>");
        skin.weights.push_back(in);
      } else if (parent_is("sampler")) {
        sampler_inputs.push_back(in);
      }
    } else if (element == "vcount" && in_prim && parent_is(prim.kind.c_str())) {
      if (prim.vcount) refuse(start, "a second <vcount> in its <" + prim.kind + ">");
      prim.vcount = true;
      std::uint64_t seen = 0;
      if (!empty)
        at = tokens(at, element, start, [&](const char* b, const char* e) {
          std::uint64_t v = 0;
          // Each value is one face's vertex count (1 and 2 make points and lines): a face of none makes the
          // triangulation assert.
          if (!parse_whole(b, e, v) || v > 0xffffffffu || v < 1)
            bad_token(b, e, element, "a face's vertex count, a whole number >= 1");
          prim.vsum += v;
          ++seen;
        });
      if (seen != prim.count)
        refuse(start, "<vcount> holds " + std::to_string(seen) + " values but its <" + prim.kind +
                          "> has count=\"" + std::to_string(prim.count) + "\"");
      continue;
    } else if ((element == "p" || element == "h") && in_prim &&
               (parent_is(prim.kind.c_str()) || parent_is("ph"))) {
      for (const DaeInput& in : prim.inputs)
        if (!known_semantic(in.semantic) && in.offset >= prim.slots)
          refuse(in.at, "<input semantic=\"" + in.semantic + "\" offset=\"" + std::to_string(in.offset) +
                            "\">: the reader skips this semantic and would read the index list with " +
                            std::to_string(prim.slots) + " indices per vertex");
      std::size_t end = at;
      const std::uint64_t got =
          empty ? 0 : index_list(at, element, start, prim.slots, prim.max, prim.seen, end);
      at = empty ? at : end;
      implied += got;
      if (element == "h") continue;
      ++prim.lists;
      const std::uint64_t slots = prim.slots;
      std::uint64_t want = 0;
      std::string why;
      if (prim.kind == "triangles") {
        want = 3 * prim.count * slots;
        why = "count " + std::to_string(prim.count) + " x 3 vertices";
      } else if (prim.kind == "polylist") {
        want = prim.vsum * slots;
        why = "the <vcount> sum " + std::to_string(prim.vsum);
      }
      if (!why.empty() && got != want)
        refuse(start, "<p> holds " + std::to_string(got) + " indices; " + why + " x " +
                          std::to_string(slots) + " inputs needs " + std::to_string(want));
      if (got % slots != 0 || (prim.kind == "lines" && got % (2 * slots) != 0))
        refuse(start, "<p> holds " + std::to_string(got) + " indices, not whole vertices of " +
                          std::to_string(slots) + " inputs" + (prim.kind == "lines" ? " in pairs" : ""));
      const std::uint64_t least = prim.kind == "tristrips" || prim.kind == "trifans" ? 3
                                  : prim.kind == "linestrips"                        ? 2
                                  : prim.kind == "polygons"                          ? 1
                                                                                     : 0;
      if (got / slots < least)
        refuse(start, "<p> of a <" + prim.kind + "> holds " + std::to_string(got / slots) +
                          " vertices (at least " + std::to_string(least) + ")");
      if (got > 0) prim.read_indices = true;
      continue;
    } else if (element == "skin" && !empty) {
      skin = DaeSkin();
      skin.mesh = reference("source");
      skin.at = start;
      in_skin = true;
    } else if (element == "bind_shape_matrix" && in_skin) {
      std::uint64_t seen = 0;
      if (!empty)
        at = tokens(at, element, start, [&](const char* b, const char* e) {
          if (!parse_finite(b, e)) bad_token(b, e, element, "a finite number");
          ++seen;
        });
      if (seen != 16) refuse(start, "<bind_shape_matrix> holds " + std::to_string(seen) + " numbers (16)");
      continue;
    } else if (element == "vertex_weights" && in_skin) {
      skin.has_weights = true;
      skin.weights_at = start;
      skin.count = whole_attr(start, tag_end, element, "count", 0, 0xffffffffu, true);
    } else if (element == "vcount" && in_skin && parent_is("vertex_weights")) {
      if (skin.vcount) refuse(start, "a second <vcount> in its <vertex_weights>");
      skin.vcount = true;
      skin.vcount_at = start;
      if (!empty)
        at = tokens(at, element, start, [&](const char* b, const char* e) {
          std::uint64_t v = 0;
          // Each value is one face's vertex count (1 and 2 make points and lines): a face of none makes the
          // triangulation assert.
          if (!parse_whole(b, e, v) || v > 0xffffffffu || v < 1)
            bad_token(b, e, element, "a face's vertex count, a whole number >= 1");
          skin.vsum += v;
          ++skin.vcount_tokens;
        });
      if (skin.vcount_tokens != skin.count)
        refuse(start, "<vcount> holds " + std::to_string(skin.vcount_tokens) +
                          " values but its <vertex_weights> has count=\"" + std::to_string(skin.count) +
                          "\"");
      continue;
    } else if (element == "v" && in_skin && parent_is("vertex_weights")) {
      if (skin.v) refuse(start, "a second <v> in its <vertex_weights>");
      skin.v = true;
      skin.v_at = start;
      std::uint64_t slots = 1;
      for (const DaeInput& in : skin.weights) slots = std::max(slots, in.offset + 1);
      std::vector<bool> seen;
      std::size_t end = at;
      const std::uint64_t got = empty ? 0 : index_list(at, element, start, slots, skin.max_v, seen, end);
      at = empty ? at : end;
      implied += got;
      if (got != skin.vsum * slots)
        refuse(start, "<v> holds " + std::to_string(got) + " indices; the <vcount> sum " +
                          std::to_string(skin.vsum) + " x " + std::to_string(slots) + " inputs needs " +
                          std::to_string(skin.vsum * slots));
      continue;
    } else if (element == "sampler") {
      sampler_id = attr("id");
      sampler_inputs.clear();
    } else if (element == "channel") {
      channels.push_back({reference("source"), attr("target"), start});
    }
    if (!empty) open.push_back(element);
  }

  // References, once every definition is known. The accessors of one <source> id are summed up (the
  // smallest count and stride, the widest element) so duplicate ids cost no more than distinct ones.
  struct Source {
    std::uint64_t count = ~std::uint64_t(0), stride = ~std::uint64_t(0), size = 0, names = 0;
    bool strings = false, numbers = false, plain = true;  // plain: every accessor has stride 1, offset 0
    std::size_t at = 0;
    std::string array;
    std::uint64_t first_offset = 0, first_stride = 1, first_count = 0;  // of its first accessor
  };
  std::unordered_map<std::string, Source> sources;
  for (const auto& [id, list] : accessors) {
    Source& src = sources[id];
    for (const DaeAccessor& a : list) {
      const auto found = arrays.find(a.array);
      if (found == arrays.end()) refuse(a.at, "<accessor source=\"#" + a.array + "\">: no array has that id");
      const DaeArrays& arr = found->second;
      if (a.offset > arr.min_count || a.count > (arr.min_count - a.offset) / a.stride)
        refuse(a.at, "<accessor source=\"#" + a.array + "\" count=\"" + std::to_string(a.count) +
                         "\" stride=\"" + std::to_string(a.stride) + "\" offset=\"" +
                         std::to_string(a.offset) + "\"> reads past the " + std::to_string(arr.min_count) +
                         " values of its array");
      if (src.array.empty()) {
        src.array = a.array;
        src.at = a.at;
        src.first_offset = a.offset;
        src.first_stride = a.stride;
        src.first_count = a.count;
      }
      src.count = std::min(src.count, a.count);
      src.stride = std::min(src.stride, a.stride);
      src.size = std::max(src.size, a.size);
      src.names = std::max(src.names, arr.max_count);
      src.strings = src.strings || arr.names;
      src.numbers = src.numbers || arr.numbers;
      src.plain = src.plain && a.stride == 1 && a.offset == 0;
    }
  }
  auto source_of = [&](const DaeInput& in, std::size_t at) -> const Source& {
    const auto found = sources.find(in.source);
    if (found == sources.end())
      refuse(at, "<input semantic=\"" + in.semantic + "\" source=\"#" + in.source +
                     "\">: no <source> with that id holds an <accessor>");
    return found->second;
  };
  auto array_kinds = [&](const Source& src, bool strings, const DaeInput& in) {
    if (strings ? src.numbers : src.strings)
      refuse(in.at, "<input semantic=\"" + in.semantic + "\" source=\"#" + in.source + "\">: its array #" +
                        src.array + (strings ? " holds numbers, not names" : " holds names, not numbers"));
  };
  for (const DaeUse& u : uses) {
    std::vector<DaeInput> through;
    if (u.vertices >= 0) {
      for (const DaeInput& in : vertices[std::size_t(u.vertices)].inputs)
        if (known_semantic(in.semantic)) through.push_back(in);
      bool position = false;
      for (const DaeInput& in : through) position = position || in.semantic == "POSITION";
      if (!position)
        refuse(u.input.at, "<input semantic=\"VERTEX\" source=\"#" + u.input.source +
                               "\">: its <vertices> has no POSITION input");
    } else {
      through.push_back(u.input);
    }
    for (const DaeInput& in : through) {
      const Source& src = source_of(in, u.input.at);
      array_kinds(src, false, in);
      if (u.max >= src.count)
        refuse(u.at, "index " + std::to_string(u.max) + " read through <input semantic=\"" +
                         u.input.semantic + "\" offset=\"" + std::to_string(u.input.offset) +
                         "\"> is past the " + std::to_string(src.count) + " elements of source #" +
                         in.source);
    }
  }
  std::unordered_multimap<std::string, std::size_t> meshes_by_geometry;
  for (std::size_t k = 0; k < meshes.size(); ++k) meshes_by_geometry.emplace(meshes[k].geometry, k);
  for (const DaeSkin& s : skins) {
    std::uint64_t joints = 0;
    for (const DaeInput& in : s.joints) {
      if (in.semantic != "JOINT") continue;
      const Source& src = source_of(in, s.at);
      array_kinds(src, true, in);
      if (!src.plain)
        refuse(src.at,
               "<accessor> of the joint names: stride and offset must be 1 and 0 (the reader reads "
               "every name of the array in order)");
      joints = std::max(joints, src.names);
    }
    for (const DaeInput& in : s.joints) {
      if (in.semantic != "INV_BIND_MATRIX") continue;
      const Source& src = source_of(in, s.at);
      array_kinds(src, false, in);
      if (src.stride < 16 || src.count < joints)
        refuse(src.at, "<accessor> of the inverse bind matrices (count " + std::to_string(src.count) +
                           ", stride " + std::to_string(src.stride) +
                           ") does not hold a 4x4 matrix for each of the " + std::to_string(joints) +
                           " joints");
    }
    if (!s.has_weights) continue;
    if (s.count > 0 && !s.vcount) refuse(s.weights_at, "<vertex_weights> has no <vcount>");
    for (const DaeInput& in : s.weights) {
      if (in.offset >= s.max_v.size()) continue;
      const std::uint64_t max = s.max_v[std::size_t(in.offset)];
      if (s.vsum == 0) continue;
      if (in.semantic == "JOINT" && max >= joints)
        refuse(s.v_at, "<v>: joint index " + std::to_string(max) + " is past the " + std::to_string(joints) +
                           " joints");
      if (in.semantic == "WEIGHT") {
        const Source& src = source_of(in, s.weights_at);
        array_kinds(src, false, in);
        if (max >= src.count)
          refuse(s.v_at, "<v>: weight index " + std::to_string(max) + " is past the " +
                             std::to_string(src.count) + " weights of source #" + in.source);
      }
    }
    const auto [first, last] = meshes_by_geometry.equal_range(s.mesh);
    for (auto it = first; it != last; ++it) {
      const DaeMesh& m = meshes[it->second];
      if (m.indexed && m.max_vertex >= s.count)
        refuse(s.weights_at, "<vertex_weights count=\"" + std::to_string(s.count) +
                                 "\">: the skinned mesh #" + s.mesh + " indexes vertex " +
                                 std::to_string(m.max_vertex) + " (count is the mesh's number of vertices)");
      implied += joints * m.primitives;
    }
    implied += s.count;
  }
  for (const DaeChannel& c : channels) {
    const auto sampler = samplers.find(c.sampler);
    if (sampler == samplers.end()) continue;  // assimp names an unresolved sampler
    for (const DaeInput& in : sampler->second) {
      if (in.semantic != "INPUT" && in.semantic != "OUTPUT") continue;
      const auto found = sources.find(in.source);
      if (found == sources.end()) continue;  // assimp names an unresolved source
      const Source& src = found->second;
      array_kinds(src, false, in);
      if (in.semantic == "OUTPUT" && target_sub_element(c.target) + src.size > 16)
        refuse(c.at, "<channel target=\"" + c.target + "\">: its OUTPUT source #" + in.source + " holds " +
                         std::to_string(src.size) + " values per key, more than the target has room for");
      implied += src.count;
      // assimp samples a rotation's ANGLE key interval once per 90 degrees turned (past 180).
      if (in.semantic == "OUTPUT" && c.target.size() > 6 &&
          c.target.compare(c.target.size() - 6, 6, ".ANGLE") == 0) {
        double turns = 0, previous = 0;
        std::uint64_t k = 0, read = 0;
        const std::size_t end = std::min(n, text.find('<', arrays[src.array].text));
        for (std::size_t at = arrays[src.array].text; at < end && read < src.first_count;) {
          while (at < end && xml_space(text[at])) ++at;
          const std::size_t b = at;
          while (at < end && !xml_space(text[at])) ++at;
          if (at == b) break;
          if (k++ < src.first_offset || (k - 1 - src.first_offset) % src.first_stride != 0) continue;
          double v = 0;
          parse_finite(text.data() + b, text.data() + at, &v);
          if (read++ > 0) turns += std::abs(v - previous) / 90;
          previous = v;
        }
        if (turns > double(kColladaValuesPerByte) * double(n) + double(1 << 20)) {
          char degrees[32];
          std::snprintf(degrees, sizeof degrees, "%.6g", turns * 90);
          refuse(c.at, "<channel target=\"" + c.target + "\">: its angles turn " + degrees +
                           " degrees, sampled every 90 degrees: more samples than the file's size allows");
        }
        implied += std::uint64_t(std::min(turns, 1e18));
      }
    }
  }
  const std::uint64_t budget = kColladaValuesPerByte * std::uint64_t(n) + (std::uint64_t(1) << 20);
  if (implied > budget)
    throw Error(file, "",
                "its counts imply " + std::to_string(implied) +
                    " values, indices and joint lists, more than " + std::to_string(budget) +
                    " for a file of " + std::to_string(n) + " bytes");
}

// ---- glTF: the node forest ----

namespace {

using GltfJson = nlohmann::json;

// glTF 2.0 (Khronos specification, section 5: buffers, bufferViews, accessors and their sparse storage):
// every offset and length checked against what it points into, in 64-bit arithmetic on whole numbers below
// 2^53, so no reader indexes past a buffer. `bin_length`: the bytes of a binary glTF's BIN chunk (the
// buffer without a uri), or -1 when there is none.
class GltfData {
 public:
  GltfData(const std::string& file, const GltfJson& doc, long long bin_length)
      : file_(file), doc_(doc), bin_length_(bin_length) {}

  void check() {
    const GltfJson& buffers = list("buffers");
    for (std::size_t b = 0; b < buffers.size(); ++b) buffer_lengths_.push_back(buffer(buffers[b], b));
    const GltfJson& views = list("bufferViews");
    for (std::size_t v = 0; v < views.size(); ++v) view(views[v], v);
    const GltfJson& accessors = list("accessors");
    for (std::size_t a = 0; a < accessors.size(); ++a) accessor(accessors[a], a);
    const GltfJson& animations = list("animations");
    for (std::size_t a = 0; a < animations.size(); ++a) animation(animations[a], a);
    // The reader copies each channel's keys out of the shared accessors: every animation (not only the
    // first, which Loom reads) and every channel, so accessors shared by many channels or animations
    // expand. At most one key value per byte of the buffers (four times what distinct accessors hold),
    // plus 2^20.
    double bytes = 0.0;
    for (const std::uint64_t b : buffer_lengths_) bytes += static_cast<double>(b);
    if (expanded_values_ > bytes + 1048576.0)
      fail("animations", "their channels read " + std::to_string(static_cast<long long>(expanded_values_)) +
                             " key values from " + std::to_string(static_cast<long long>(bytes)) +
                             " bytes of buffers (more than one per byte plus 2^20): accessors shared by many "
                             "channels or animations expand when read");
    const GltfJson& meshes = list("meshes");
    for (std::size_t m = 0; m < meshes.size(); ++m) mesh(meshes[m], m);
  }

 private:
  static constexpr std::uint64_t kMaxWhole = std::uint64_t(1) << 53;

  [[noreturn]] void fail(const std::string& where, const std::string& problem) const {
    throw Error(file_, where, problem);
  }
  const GltfJson& list(const char* key) const {
    static const GltfJson empty = GltfJson::array();
    const auto it = doc_.find(key);
    if (it == doc_.end()) return empty;
    if (!it->is_array()) fail(key, "must be an array");
    return *it;
  }
  static std::string at(const std::string& parent, std::size_t k) {
    return parent + "[" + std::to_string(k) + "]";
  }
  // A whole number in [lo, 2^53) at obj[key] (`fallback` when absent; nullopt fallback: required).
  std::uint64_t whole(const GltfJson& obj, const std::string& where, const char* key,
                      std::optional<std::uint64_t> fallback, std::uint64_t lo = 0) const {
    if (!obj.is_object()) fail(where, "must be an object");
    const auto it = obj.find(key);
    if (it == obj.end()) {
      if (!fallback) fail(where + "." + key, "is required");
      return *fallback;
    }
    const bool whole_number =
        it->is_number_unsigned() || (it->is_number_integer() && it->get<long long>() >= 0);
    if (!whole_number || it->get<std::uint64_t>() < lo || it->get<std::uint64_t>() >= kMaxWhole)
      fail(where + "." + key, "must be a whole number in [" + std::to_string(lo) + ", 2^53) (got " +
                                  show_value(it->dump(), 40) + ")");
    return it->get<std::uint64_t>();
  }
  std::uint64_t index(const GltfJson& obj, const std::string& where, const char* key, std::size_t count,
                      const char* what) const {
    const std::uint64_t i = whole(obj, where, key, std::nullopt);
    if (i >= count)
      fail(where + "." + key,
           "names " + std::string(what) + " " + std::to_string(i) + " of " + std::to_string(count));
    return i;
  }
  void within(const std::string& where, std::uint64_t end, std::uint64_t length,
              const std::string& of) const {
    if (end > length)
      fail(where,
           "reaches byte " + std::to_string(end) + " of " + of + ", which has " + std::to_string(length));
  }

  std::uint64_t buffer(const GltfJson& b, std::size_t k) const {
    const std::string where = at("buffers", k);
    const std::uint64_t length = whole(b, where, "byteLength", std::nullopt, 1);
    const auto uri = b.find("uri");
    if (uri == b.end()) {
      if (bin_length_ < 0) fail(where, "has no uri and the file has no binary (BIN) chunk");
      if (k != 0) fail(where, "has no uri: only buffers[0] can be a binary glTF's BIN chunk");
      within(where + ".byteLength", length, static_cast<std::uint64_t>(bin_length_), "the BIN chunk");
    } else if (!uri->is_string()) {
      fail(where + ".uri", "must be a string");
    } else if (uri->get<std::string>().rfind("data:", 0) != 0) {
      // A file beside the clip: a relative path that stays in the clip's folder or below it, checked as
      // written and with its percent-escapes (%2E is '.') decoded.
      const std::string& written = uri->get_ref<const std::string&>();
      std::string path;
      for (std::size_t k = 0; k < written.size(); ++k) {
        if (written[k] == '%' && k + 2 < written.size() &&
            std::isxdigit(static_cast<unsigned char>(written[k + 1])) &&
            std::isxdigit(static_cast<unsigned char>(written[k + 2]))) {
          path += static_cast<char>(std::stoi(written.substr(k + 1, 2), nullptr, 16));
          k += 2;
        } else {
          path += written[k];
        }
      }
      bool outside = path.empty() || path[0] == '/' || path[0] == '\\' || path.find(':') != std::string::npos;
      for (std::size_t at = 0; at <= path.size() && !outside;) {
        const std::size_t end = std::min(path.find_first_of("/\\", at), path.size());
        outside = path.compare(at, end - at, "..") == 0 && end - at == 2;
        at = end + 1;
      }
      if (outside)
        fail(where + ".uri",
             "'" + show_value(written, 80) +
                 "' is not a file beside the clip (a relative path without '..', or a data URI)");
    } else {
      // A data URI: ";base64," then 4 characters per 3 bytes.
      const std::string& text = uri->get_ref<const std::string&>();
      const std::size_t comma = text.find(',');
      if (comma == std::string::npos || text.rfind(";base64", comma) != comma - 7)
        fail(where + ".uri", "a data URI must be base64 (data:...;base64,...)");
      std::uint64_t chars = text.size() - comma - 1;
      while (chars > 0 && text[comma + chars] == '=') --chars;
      within(where + ".byteLength", length, chars * 3 / 4, "its data URI");
    }
    return length;
  }

  void view(const GltfJson& v, std::size_t k) {
    const std::string where = at("bufferViews", k);
    const std::uint64_t b = index(v, where, "buffer", buffer_lengths_.size(), "buffer");
    const std::uint64_t offset = whole(v, where, "byteOffset", 0);
    const std::uint64_t length = whole(v, where, "byteLength", std::nullopt, 1);
    within(where + ".byteLength", offset + length, buffer_lengths_[b], at("buffers", b));
    const std::uint64_t stride = whole(v, where, "byteStride", 0);
    if (v.contains("byteStride") && (stride < 4 || stride > 252 || stride % 4 != 0))
      fail(where + ".byteStride", "must be a multiple of 4 in [4, 252] (got " + std::to_string(stride) + ")");
    views_.push_back({length, stride});
  }

  static std::uint64_t component_bytes(std::uint64_t type) {
    switch (type) {
      case 5120:  // BYTE
      case 5121:  // UNSIGNED_BYTE
        return 1;
      case 5122:  // SHORT
      case 5123:  // UNSIGNED_SHORT
        return 2;
      case 5125:  // UNSIGNED_INT
      case 5126:  // FLOAT
        return 4;
      default:
        return 0;
    }
  }

  void accessor(const GltfJson& a, std::size_t k) {
    const std::string where = at("accessors", k);
    const std::uint64_t component = component_bytes(whole(a, where, "componentType", std::nullopt));
    if (component == 0) fail(where + ".componentType", "must be 5120, 5121, 5122, 5123, 5125 or 5126");
    static const std::unordered_map<std::string, std::uint64_t> kComponents = {
        {"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4}, {"MAT2", 4}, {"MAT3", 9}, {"MAT4", 16}};
    const auto type = a.find("type");
    if (type == a.end() || !type->is_string() || !kComponents.count(type->get<std::string>()))
      fail(where + ".type", "must be SCALAR, VEC2, VEC3, VEC4, MAT2, MAT3 or MAT4");
    const std::uint64_t element = component * kComponents.at(type->get<std::string>());
    const std::uint64_t count = whole(a, where, "count", std::nullopt, 1);
    accessors_.push_back({count, type->get<std::string>(), a["componentType"].get<std::uint64_t>()});
    const std::uint64_t offset = whole(a, where, "byteOffset", 0);
    if (a.contains("bufferView")) {
      const View& view = views_[index(a, where, "bufferView", views_.size(), "buffer view")];
      const std::uint64_t stride = view.stride ? view.stride : element;
      within(where + ".count", offset + stride * (count - 1) + element, view.length,
             at("bufferViews", a["bufferView"].get<std::size_t>()));
    }
    const auto sparse = a.find("sparse");
    if (sparse == a.end()) return;
    const std::string s = where + ".sparse";
    const std::uint64_t patched = whole(*sparse, s, "count", std::nullopt, 1);
    if (patched > count)
      fail(s + ".count",
           std::to_string(patched) + " is more than the accessor's count " + std::to_string(count));
    for (const char* part : {"indices", "values"}) {
      const std::string p = s + "." + part;
      const auto it = sparse->find(part);
      if (it == sparse->end()) fail(p, "is required");
      const std::uint64_t v = index(*it, p, "bufferView", views_.size(), "buffer view");
      std::uint64_t size = element;
      if (std::string(part) == "indices") {
        const std::uint64_t t = whole(*it, p, "componentType", std::nullopt);
        size = t == 5121 || t == 5123 || t == 5125 ? component_bytes(t) : 0;
        if (size == 0) fail(p + ".componentType", "must be 5121, 5123 or 5125");
      }
      within(p + ".byteOffset", whole(*it, p, "byteOffset", 0) + patched * size, views_[v].length,
             at("bufferViews", v));
    }
  }

  // A channel that moves a node (translation, rotation, scale) reads its sampler's output as one value per
  // key time (three for CUBICSPLINE: in-tangent, value, out-tangent) of the path's type, and its input as
  // scalar times.
  void animation(const GltfJson& anim, std::size_t k) {
    const std::string where = at("animations", k);
    if (!anim.is_object()) fail(where, "must be an object");
    static const GltfJson empty = GltfJson::array();
    const GltfJson& samplers = anim.contains("samplers") ? anim["samplers"] : empty;
    const GltfJson& channels = anim.contains("channels") ? anim["channels"] : empty;
    if (!samplers.is_array()) fail(where + ".samplers", "must be an array");
    if (!channels.is_array()) fail(where + ".channels", "must be an array");
    static const std::unordered_map<std::string, std::string> kPathType = {
        {"translation", "VEC3"}, {"rotation", "VEC4"}, {"scale", "VEC3"}};
    for (std::size_t c = 0; c < channels.size(); ++c) {
      const std::string cw = where + at(".channels", c);
      const std::uint64_t si = index(channels[c], cw, "sampler", samplers.size(), "sampler");
      const auto target = channels[c].find("target");
      if (target == channels[c].end() || !target->is_object()) fail(cw + ".target", "is required");
      const auto path = target->find("path");
      if (path == target->end() || !path->is_string()) fail(cw + ".target.path", "is required");
      const auto type = kPathType.find(path->get<std::string>());
      if (type == kPathType.end()) continue;  // morph weights: not read as a node's motion
      const GltfJson& sampler = samplers[si];
      const std::string sw = where + at(".samplers", si);
      const Accessor& in = accessors_[index(sampler, sw, "input", accessors_.size(), "accessor")];
      const Accessor& out = accessors_[index(sampler, sw, "output", accessors_.size(), "accessor")];
      if (in.type != "SCALAR" || in.component != 5126)
        fail(sw + ".input", "must be a SCALAR FLOAT (5126) accessor of key times");
      if (out.component != 5126)
        fail(sw + ".output", "must be a FLOAT (5126) accessor: Loom reads a node's keys as floats");
      if (out.type != type->second)
        fail(sw + ".output", "must be a " + type->second + " accessor for a " + path->get<std::string>() +
                                 " channel (got " + out.type + ")");
      const auto interpolation = sampler.find("interpolation");
      const bool cubic = interpolation != sampler.end() && *interpolation == "CUBICSPLINE";
      expanded_values_ += static_cast<double>(in.count) +
                          static_cast<double>(out.count) * (type->second == "VEC4" ? 4.0 : 3.0);
      if (out.count != (cubic ? 3 : 1) * in.count)
        fail(sw + ".output", "has " + std::to_string(out.count) + " values for " + std::to_string(in.count) +
                                 " key times (" + (cubic ? "3 per key for CUBICSPLINE" : "1 per key") + ")");
    }
  }

  // A primitive's accessors exist, its indices are unsigned scalars, and it has the vertices its mode
  // needs (points 1, lines 2, triangles 3: a strip of one index made the reader allocate 2^64 - 1 bytes).
  void mesh(const GltfJson& m, std::size_t k) const {
    const std::string where = at("meshes", k);
    if (!m.is_object()) fail(where, "must be an object");
    const auto primitives = m.find("primitives");
    if (primitives == m.end()) return;
    if (!primitives->is_array()) fail(where + ".primitives", "must be an array");
    for (std::size_t p = 0; p < primitives->size(); ++p) {
      const GltfJson& prim = (*primitives)[p];
      const std::string pw = where + at(".primitives", p);
      const std::uint64_t mode = whole(prim, pw, "mode", 4);
      if (mode > 6)
        fail(pw + ".mode", "must be 0 to 6 (points, lines, line loop, line strip, triangles, strip, fan)");
      std::uint64_t vertices = 0;
      const auto attributes = prim.find("attributes");
      if (attributes == prim.end() || !attributes->is_object()) fail(pw + ".attributes", "must be an object");
      for (auto it = attributes->begin(); it != attributes->end(); ++it) {
        const std::uint64_t a =
            index(*attributes, pw + ".attributes", it.key().c_str(), accessors_.size(), "accessor");
        if (it.key() == "POSITION") vertices = accessors_[a].count;
      }
      if (prim.contains("indices")) {
        const Accessor& indices = accessors_[index(prim, pw, "indices", accessors_.size(), "accessor")];
        if (indices.type != "SCALAR" ||
            !(indices.component == 5121 || indices.component == 5123 || indices.component == 5125))
          fail(pw + ".indices", "must be a SCALAR accessor of unsigned integers (5121, 5123 or 5125)");
        vertices = indices.count;
      }
      const std::uint64_t least = mode == 0 ? 1 : mode <= 3 ? 2 : 3;
      if (vertices < least)
        fail(pw, "has " + std::to_string(vertices) + " vertices (indices, or POSITION values); its mode " +
                     std::to_string(mode) + " needs at least " + std::to_string(least));
    }
  }

  struct View {
    std::uint64_t length, stride;
  };
  struct Accessor {
    std::uint64_t count;
    std::string type;
    std::uint64_t component;
  };
  std::vector<Accessor> accessors_;
  double expanded_values_ = 0.0;  // key values the reader copies out for all channels of all animations
  const std::string& file_;
  const GltfJson& doc_;
  long long bin_length_;
  std::vector<std::uint64_t> buffer_lengths_;
  std::vector<View> views_;
};

}  // namespace

void check_gltf_nodes(const std::string& file, const std::string& text) {
  using Json = nlohmann::json;
  std::size_t begin = 0, end = text.size();
  long long bin_length = -1;              // bytes of a binary glTF's BIN chunk
  if (text.compare(0, 4, "glTF") == 0) {  // binary glTF: a 12-byte header, then the JSON chunk
    if (text.size() < 20 || text.compare(16, 4, "JSON") != 0) return;
    const std::uint64_t length = std::uint64_t(static_cast<unsigned char>(text[12])) |
                                 std::uint64_t(static_cast<unsigned char>(text[13])) << 8 |
                                 std::uint64_t(static_cast<unsigned char>(text[14])) << 16 |
                                 std::uint64_t(static_cast<unsigned char>(text[15])) << 24;
    begin = 20;
    end = static_cast<std::size_t>(std::min<std::uint64_t>(text.size(), 20 + length));
    // The BIN chunk, if any, follows the JSON chunk padded to 4 bytes: its length (what the file holds of
    // it) and "BIN\0".
    const std::uint64_t bin = 20 + (length + 3) / 4 * 4;
    if (bin + 8 <= text.size() && text.compare(bin + 4, 4, std::string("BIN\0", 4)) == 0)
      bin_length = static_cast<long long>(std::min<std::uint64_t>(
          text.size() - bin - 8, std::uint64_t(static_cast<unsigned char>(text[bin])) |
                                     std::uint64_t(static_cast<unsigned char>(text[bin + 1])) << 8 |
                                     std::uint64_t(static_cast<unsigned char>(text[bin + 2])) << 16 |
                                     std::uint64_t(static_cast<unsigned char>(text[bin + 3])) << 24));
  } else {
    if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) begin = 3;
    while (begin < end && std::isspace(static_cast<unsigned char>(text[begin]))) ++begin;
    if (begin >= end || text[begin] != '{') return;
  }
  // Only "nodes", "scenes", the data's layout ("buffers", "bufferViews", "accessors") and "animations"
  // are kept (the rest, images as data URIs included, is parsed and dropped).
  // The document must read the same to this check and to assimp's reader: text that is not JSON (bytes
  // that are not UTF-8 included, which assimp's reader passes) and a key given twice in one object (this
  // reader keeps the last, assimp's the first) are refused, so no node graph goes unchecked.
  // keys[d]: the keys seen so far of the object open at depth d - 1 (an object started at depth d has its
  // keys at depth d + 1; the callback is not told every object's end, so a start clears its level).
  std::vector<std::set<std::string>> keys;
  std::string twice;  // the first key given twice
  const Json::parser_callback_t keep = [&](int depth, Json::parse_event_t event, Json& parsed) {
    const std::size_t d = static_cast<std::size_t>(std::max(depth, 0));
    if (event == Json::parse_event_t::object_start) {
      if (keys.size() < d + 2) keys.resize(d + 2);
      keys[d + 1].clear();
    }
    if (event == Json::parse_event_t::key) {
      if (keys.size() < d + 1) keys.resize(d + 1);
      if (!keys[d].insert(parsed.get<std::string>()).second && twice.empty())
        twice = parsed.get<std::string>();
    }
    static const std::set<std::string> kKept = {"nodes",     "scenes",     "buffers", "bufferViews",
                                                "accessors", "animations", "meshes",  "asset"};
    return !(depth == 1 && event == Json::parse_event_t::key && !kKept.count(parsed.get<std::string>()));
  };
  check_json_nesting(file, text.substr(begin, end - begin), kMaxGltfJsonDepth);
  Json doc;
  try {
    doc = Json::parse(text.begin() + static_cast<std::ptrdiff_t>(begin),
                      text.begin() + static_cast<std::ptrdiff_t>(end), keep, true);
  } catch (const Json::exception& e) {
    throw Error(file, "",
                std::string("not JSON Loom can check before reading it: ") + show_value(e.what(), 160));
  }
  if (!twice.empty())
    throw Error(file, "",
                "the key '" + show_value(twice) +
                    "' is given twice in one object: readers differ on which one counts, so none is taken");
  if (!doc.is_object()) return;
  // glTF 1.0 (its buffers, views and accessors are dictionaries, read by assimp's older reader) is not
  // checked here: the layout rules are glTF 2.0's.
  const auto asset = doc.find("asset");
  const Json version =
      asset != doc.end() && asset->is_object() && asset->contains("version") ? (*asset)["version"] : Json();
  const bool version1 = (version.is_string() && version.get<std::string>().rfind('1', 0) == 0) ||
                        (version.is_number() && version.get<double>() < 2.0);
  if (!version1) GltfData(file, doc, bin_length).check();
  const auto nodes = doc.find("nodes");
  if (nodes == doc.end() || !nodes->is_array()) return;
  const std::size_t count = nodes->size();
  if (count > kMaxExpandedNodes)
    throw Error(file, "nodes", "more than " + std::to_string(kMaxExpandedNodes) + " nodes");
  auto name = [&](std::size_t k) { return "nodes[" + std::to_string(k) + "]"; };
  std::vector<long> parent(count, -1);
  std::vector<std::vector<std::size_t>> children(count);
  for (std::size_t k = 0; k < count; ++k) {
    const Json& node = (*nodes)[k];
    if (!node.is_object()) continue;
    const auto list = node.find("children");
    if (list == node.end() || !list->is_array()) continue;
    for (const Json& c : *list) {
      if (!c.is_number_integer() || c.get<long long>() < 0 || c.get<unsigned long long>() >= count)
        continue;  // assimp names an index out of range
      const std::size_t child = c.get<std::size_t>();
      if (parent[child] == long(k))
        throw Error(
            file, name(k) + ".children",
            "lists " + name(child) + " twice (a glTF node has one parent, each child is listed once)");
      if (parent[child] >= 0)
        throw Error(file, name(k) + ".children",
                    name(child) + " is already a child of " + name(std::size_t(parent[child])) +
                        " (a glTF node has at most one parent: the node tree would be copied per parent)");
      parent[child] = long(k);
      children[k].push_back(child);
    }
  }
  // Each node has one parent at most: a cycle shows as a walk up the parents that meets itself.
  std::vector<std::size_t> walk(count, 0);  // the start (+1) of the walk that passed a node
  for (std::size_t s = 0; s < count; ++s) {
    long v = long(s);
    while (v >= 0 && walk[std::size_t(v)] == 0) {
      walk[std::size_t(v)] = s + 1;
      v = parent[std::size_t(v)];
    }
    if (v >= 0 && walk[std::size_t(v)] == s + 1)
      throw Error(
          file, name(std::size_t(v)),
          "the node is its own ancestor (its children lead back to it): the node tree would never end");
  }
  std::vector<std::uint64_t> size(count, 1);  // nodes in each subtree, children before parents
  std::vector<std::pair<std::size_t, std::size_t>> stack;
  for (std::size_t r = 0; r < count; ++r) {
    if (parent[r] >= 0) continue;
    stack.push_back({r, 0});
    while (!stack.empty()) {
      auto& [v, next] = stack.back();
      if (next < children[v].size()) {
        const std::size_t c = children[v][next++];
        stack.push_back({c, 0});
        continue;
      }
      const std::size_t done = v;
      stack.pop_back();
      if (!stack.empty()) size[stack.back().first] += size[done];
    }
  }
  const auto scenes = doc.find("scenes");
  if (scenes == doc.end() || !scenes->is_array()) return;
  for (std::size_t s = 0; s < scenes->size(); ++s) {
    const Json& scene = (*scenes)[s];
    if (!scene.is_object()) continue;
    const auto roots = scene.find("nodes");
    if (roots == scene.end() || !roots->is_array()) continue;
    std::uint64_t total = 0;
    for (const Json& r : *roots)
      if (r.is_number_integer() && r.get<long long>() >= 0 && r.get<unsigned long long>() < count)
        total = saturating_add(total, size[r.get<std::size_t>()]);
    if (total > kMaxExpandedNodes)
      throw Error(file, "scenes[" + std::to_string(s) + "].nodes",
                  "the scene's root nodes expand to more than " + std::to_string(kMaxExpandedNodes) +
                      " nodes (a root listed again is copied again)");
  }
}

// ---- FBX: scope nesting ----

namespace {

std::uint64_t little_endian(const std::string& s, std::size_t at, int bytes) {
  std::uint64_t v = 0;
  for (int b = bytes - 1; b >= 0; --b) v = v << 8 | static_cast<unsigned char>(s[at + std::size_t(b)]);
  return v;
}

// Binary FBX node records: [end offset, property count, property bytes, name length (1 byte), name,
// properties, nested records, a null record of the header's size], words of 4 bytes before version 7500
// and 8 from it; the top-level list ends with a null record.
void check_fbx_binary(const std::string& file, const std::string& text) {
  if (text.size() < 27) return;  // assimp names a cut header
  const bool wide = little_endian(text, 23, 4) >= 7500;
  const int word = wide ? 8 : 4;
  const std::uint64_t header = 3 * std::uint64_t(word) + 1, size = text.size();
  auto bad = [&](std::uint64_t at, const std::string& problem) {
    throw Error(file, "byte " + std::to_string(at), "FBX node record: " + problem);
  };
  std::vector<std::pair<std::uint64_t, std::uint64_t>> open;  // (nested list's end, record's end)
  std::uint64_t at = 27;
  for (;;) {
    while (!open.empty() && at >= open.back().first) {
      if (at != open.back().first) bad(at, "runs past the end of its parent's nested records");
      at = open.back().second;
      open.pop_back();
    }
    if (at + header > size) {
      if (open.empty()) return;  // the footer, or a cut file assimp names
      bad(at, "the file ends inside a nested record");
    }
    const std::uint64_t end = little_endian(text, std::size_t(at), word);
    if (end == 0) {
      if (open.empty()) return;  // the null record that ends the top level
      bad(at, "a null record inside a nested list");
    }
    if (end > size || end < at + header)
      bad(at, "end offset " + std::to_string(end) + " is out of range (the file has " + std::to_string(size) +
                  " bytes)");
    const std::uint64_t properties = little_endian(text, std::size_t(at + 2 * std::uint64_t(word)), word);
    const std::uint64_t name = static_cast<unsigned char>(text[std::size_t(at + 3 * std::uint64_t(word))]);
    if (properties > end || at + header + name + properties > end)
      bad(at, "its name and properties run past its end offset " + std::to_string(end));
    const std::uint64_t body = at + header + name + properties;
    if (body == end) {
      at = end;
      continue;
    }
    if (end - body < header) bad(at, "too short for the null record that ends its nested records");
    open.push_back({end - header, end});
    if (open.size() > std::size_t(kMaxFbxDepth))
      throw Error(file, "byte " + std::to_string(at),
                  "FBX node records nest more than " + std::to_string(kMaxFbxDepth) + " levels deep");
    at = body;
  }
}

bool looks_like_ascii_fbx(const std::string& file, const std::string& text) {
  std::string ext = std::filesystem::path(file).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".fbx") return true;
  std::string head = text.substr(0, 200);
  for (char& c : head) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return head.find("fbx") != std::string::npos;
}

}  // namespace

void check_fbx_nesting(const std::string& file, const std::string& text) {
  // Assimp takes a file for binary FBX by its first 18 bytes (the rest of the 21-byte magic unchecked).
  if (text.compare(0, 18, "Kaydara FBX Binary") == 0) return check_fbx_binary(file, text);
  if (!looks_like_ascii_fbx(file, text)) return;
  int depth = 0;
  bool quoted = false;
  for (std::size_t at = 0; at < text.size(); ++at) {
    const char c = text[at];
    if (quoted) {
      quoted = c != '"';
    } else if (c == ';') {  // a comment, to the end of its line: CR, LF, FF or NUL, as assimp's tokenizer
      at = text.find_first_of(std::string("\r\n\f\0", 4), at);
      if (at == std::string::npos) return;
    } else if (c == '"') {
      quoted = true;
    } else if (c == '{') {
      if (++depth > kMaxFbxDepth)
        throw Error(file, line_at(text, at),
                    "FBX scopes ('{') nest more than " + std::to_string(kMaxFbxDepth) + " levels deep");
    } else if (c == '}') {
      depth = std::max(0, depth - 1);
    }
  }
}

}  // namespace loom::characters
