#include "loom/cloth/InputFile.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"

namespace fs = std::filesystem;

namespace loom {

namespace {

std::string show_size(std::uint64_t bytes) {
  char s[48];
  if (bytes >= 1000000000)
    std::snprintf(s, sizeof s, "%.3g GB", static_cast<double>(bytes) / 1e9);
  else if (bytes >= 1000000)
    std::snprintf(s, sizeof s, "%.3g MB", static_cast<double>(bytes) / 1e6);
  else
    std::snprintf(s, sizeof s, "%llu bytes", static_cast<unsigned long long>(bytes));
  return s;
}

// Why an input file cannot be opened, from the errno of stat or open: every input file (scene, mesh, clip,
// character mesh, checkpoint) is opened through check_input_file and read_input_file, so this is the one
// wording of the system's reason ("no such file" only for ENOENT).
std::string open_error_text(int err) {
  switch (err) {
    case ENOENT:
      return "no such file";
    case ELOOP:
      return "a loop of symbolic links (or too many of them on the way)";
    case EACCES:
    case EPERM:
      return "permission denied";
    case ENOTDIR:
      return "a component of the path is not a folder";
    case ENAMETOOLONG:
      return "the path or a name in it is too long";
    case EISDIR:
      return "is a folder, not a file";
    default:
      return std::strerror(err);
  }
}

// The problem of an input file that cannot be opened.
std::string open_problem(int err) {
  return err == ENOENT ? "no such file (cannot open it)" : "cannot open it: " + open_error_text(err);
}

}  // namespace

void check_input_file(const std::string& path, std::uint64_t max_bytes) {
  if (path.empty()) throw Error("", "", "an input file path is empty");
  std::error_code ec;
  struct stat sb;
  // Follows links (a link to /dev/zero is a device); the system's reason when it fails: a loop of links or
  // a folder without access is not "no such file".
  if (::stat(path.c_str(), &sb) != 0) {
    const int err = errno;
    throw Error(path, "", open_problem(err));
  }
  const fs::file_status st = fs::status(path, ec);
  if (fs::is_directory(st)) throw Error(path, "", "is a folder, not a file");
  if (!fs::is_regular_file(st)) throw Error(path, "", "is not a regular file (a device, pipe or socket)");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw Error(path, "", "cannot read its size: " + ec.message());
  if (size > max_bytes)
    throw Error(path, "",
                "is " + show_size(size) + ", more than the " + show_size(max_bytes) + " Loom reads");
}

std::string read_input_file(const std::string& path, std::uint64_t max_bytes) {
  check_input_file(path, max_bytes);
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int err = errno;
    throw Error(path, "", err ? open_problem(err) : std::string("cannot open it"));
  }
  std::string text;
  char buffer[1 << 16];
  while (in) {
    in.read(buffer, sizeof buffer);
    text.append(buffer, static_cast<size_t>(in.gcount()));
    if (text.size() > max_bytes)
      throw Error(path, "", "grew past " + show_size(max_bytes) + " while it was read");
  }
  if (in.bad()) throw Error(path, "", "read failed");
  return text;
}

void for_each_input_line(const std::string& text, const std::function<void(const std::string&)>& visit) {
  size_t start = text.compare(0, 3, "\xef\xbb\xbf") == 0 ? 3 : 0;
  for (size_t i = start; i < text.size(); ++i) {
    if (text[i] != '\n' && text[i] != '\r') continue;
    visit(text.substr(start, i - start));
    if (text[i] == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
    start = i + 1;
  }
  if (start < text.size()) visit(text.substr(start));
}

void check_json_nesting(const std::string& file, const std::string& text, int max_depth) {
  int depth = 0;
  bool in_string = false;
  long line = 1;
  std::size_t line_start = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') line += 1, line_start = i + 1;
    if (in_string) {
      if (c == '\\')
        ++i;  // the escaped character cannot end the string
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth)
        throw Error(file, "line " + std::to_string(line) + ", column " + std::to_string(i - line_start + 1),
                    "JSON arrays and objects nest deeper than " + std::to_string(max_depth) + " levels");
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
}

std::string line_where(long number, const std::string& line) {
  std::string quoted = show_hidden(line.substr(0, kQuotedChars));
  if (line.size() > kQuotedChars) quoted += "...";
  return "line " + std::to_string(number) + " ('" + quoted + "')";
}

}  // namespace loom
