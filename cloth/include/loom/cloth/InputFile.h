#pragma once
// The one way Loom reads a file it is given (scene, OBJ mesh, collider mesh, motion, garment groups, CCD
// queries, checkpoint): the path must name a regular file (a symbolic link is followed to its target; a
// folder, a device such as /dev/zero, a pipe or a socket is refused before anything is read) of at most
// `max_bytes`. Errors are loom::Error naming the path and the problem.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace loom {

constexpr std::uint64_t kMaxInputFileBytes = std::uint64_t(1) << 30;  // 1 GiB

// Throws loom::Error(path, "", problem) unless `path` is a regular file of at most `max_bytes`.
void check_input_file(const std::string& path, std::uint64_t max_bytes = kMaxInputFileBytes);
// The whole file, after check_input_file; reading stops at `max_bytes` even if the file grew meanwhile.
std::string read_input_file(const std::string& path, std::uint64_t max_bytes = kMaxInputFileBytes);

// Calls `visit` with each line of `text`, in order, one at a time (a reader keeps no copy of the file's
// lines, so its memory is what it builds): a line ends at "\n", "\r\n" or a lone "\r" (old Mac line
// endings), so a line number always counts the lines an editor shows, never the whole file as line 1. A
// leading UTF-8 byte order mark is dropped.
void for_each_input_line(const std::string& text, const std::function<void(const std::string&)>& visit);
// Refuses JSON `text` whose arrays and objects nest deeper than `max_depth` (brackets outside strings are
// counted before any parser builds or walks the tree: a parser's work and stack grow with the depth), with
// Error(file, "line L, column C", ...) at the first bracket past it.
void check_json_nesting(const std::string& file, const std::string& text, int max_depth);
// Characters of a line that line_where quotes; a longer line is quoted as its first kQuotedChars and "...".
constexpr std::size_t kQuotedChars = 80;
// "line N ('TEXT')": where an error in a text file is, quoting the faulty line itself (at most kQuotedChars
// characters, control characters shown as \xNN).
std::string line_where(long number, const std::string& line);

}  // namespace loom
