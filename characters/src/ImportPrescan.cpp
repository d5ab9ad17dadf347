#include "ImportPrescan.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <unordered_map>
#include <utility>
#include <vector>

#include "loom/cloth/Error.h"

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

// The attribute `key` of the start tag text[begin, end) ("" if absent); values in ' or " quotes.
std::string attribute(const std::string& text, std::size_t begin, std::size_t end, const char* key) {
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
    if (at >= end || (text[at] != '"' && text[at] != '\'')) return "";
    const char quote = text[at++];
    const std::size_t value = at;
    while (at < end && text[at] != quote) ++at;
    if (name_end - name == key_size && text.compare(name, key_size, key) == 0)
      return text.substr(value, at - value);
    ++at;
  }
  return "";
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
      int brackets = 0;
      for (++at; at < n && !(text[at] == '>' && brackets <= 0); ++at)
        brackets += text[at] == '[' ? 1 : text[at] == ']' ? -1 : 0;
      ++at;
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

// ---- glTF: the node forest ----

void check_gltf_nodes(const std::string& file, const std::string& text) {
  using Json = nlohmann::json;
  std::size_t begin = 0, end = text.size();
  if (text.compare(0, 4, "glTF") == 0) {  // binary glTF: a 12-byte header, then the JSON chunk
    if (text.size() < 20 || text.compare(16, 4, "JSON") != 0) return;
    const std::uint64_t length = std::uint64_t(static_cast<unsigned char>(text[12])) |
                                 std::uint64_t(static_cast<unsigned char>(text[13])) << 8 |
                                 std::uint64_t(static_cast<unsigned char>(text[14])) << 16 |
                                 std::uint64_t(static_cast<unsigned char>(text[15])) << 24;
    begin = 20;
    end = static_cast<std::size_t>(std::min<std::uint64_t>(text.size(), 20 + length));
  } else {
    if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) begin = 3;
    while (begin < end && std::isspace(static_cast<unsigned char>(text[begin]))) ++begin;
    if (begin >= end || text[begin] != '{') return;
  }
  // Only "nodes" and "scenes" are kept (the rest, buffers as data URIs included, is parsed and dropped).
  const Json::parser_callback_t keep = [](int depth, Json::parse_event_t event, Json& parsed) {
    return !(depth == 1 && event == Json::parse_event_t::key && parsed != "nodes" && parsed != "scenes");
  };
  const Json doc = Json::parse(text.begin() + static_cast<std::ptrdiff_t>(begin),
                               text.begin() + static_cast<std::ptrdiff_t>(end), keep, false);
  if (doc.is_discarded() || !doc.is_object()) return;
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
  if (text.compare(0, 21, std::string("Kaydara FBX Binary  \0", 21)) == 0)
    return check_fbx_binary(file, text);
  if (!looks_like_ascii_fbx(file, text)) return;
  int depth = 0;
  bool quoted = false;
  for (std::size_t at = 0; at < text.size(); ++at) {
    const char c = text[at];
    if (quoted) {
      quoted = c != '"';
    } else if (c == ';') {  // a comment, to the end of its line
      at = text.find('\n', at);
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
