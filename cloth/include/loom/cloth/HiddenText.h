#pragma once
// Characters of input text (scene strings, file names, quoted file lines) that must never reach a terminal
// or an output file as they are: C0 controls and DEL (a newline, an escape, a NUL), C1 controls
// (U+0080-U+009F), the line and paragraph separators U+2028 and U+2029 (a line break to many readers), and
// every character that is invisible or reorders text: Unicode's Default_Ignorable_Code_Point set (bidi
// controls, zero-width characters, the soft hyphen, fillers, variation selectors, tag characters; Unicode
// 15, DerivedCoreProperties.txt) and the other format characters (General_Category Cf: the Arabic number
// signs U+0600-U+0605, U+06DD, U+070F, U+0890-U+0891, U+08E2, U+110BD, U+110CD, the interlinear annotation
// controls U+FFF9-U+FFFB, Egyptian format controls U+13430-U+1343F). Text is UTF-8; a byte that does not
// start a valid UTF-8 sequence is taken as is.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace loom {

struct HiddenChar {
  std::size_t byte = 0;    // offset of its first byte in the text
  std::size_t length = 1;  // its UTF-8 length in bytes
  std::uint32_t code = 0;  // its code point
};

// True for a code point in the set above.
inline bool is_hidden_code(std::uint32_t c) {
  if (c < 0x20 || c == 0x7f || (c >= 0x80 && c <= 0x9f)) return true;
  if (c < 0xad) return false;  // printable ASCII and Latin-1 (fast path)
  static constexpr std::uint32_t kRanges[][2] = {
      {0x00ad, 0x00ad},   {0x034f, 0x034f},   {0x0600, 0x0605},   {0x061c, 0x061c},   {0x06dd, 0x06dd},
      {0x070f, 0x070f},   {0x0890, 0x0891},   {0x08e2, 0x08e2},   {0x115f, 0x1160},   {0x17b4, 0x17b5},
      {0x180b, 0x180f},   {0x200b, 0x200f},   {0x2028, 0x202e},   {0x2060, 0x206f},   {0x3164, 0x3164},
      {0xfe00, 0xfe0f},   {0xfeff, 0xfeff},   {0xffa0, 0xffa0},   {0xfff0, 0xfffb},   {0x110bd, 0x110bd},
      {0x110cd, 0x110cd}, {0x13430, 0x1343f}, {0x1bca0, 0x1bca3}, {0x1d173, 0x1d17a}, {0xe0000, 0xe0fff}};
  for (const auto& r : kRanges)
    if (c >= r[0] && c <= r[1]) return true;
  return false;
}

// The character at byte `i` of `s` (decoded from UTF-8; an invalid sequence is one byte, its value).
inline HiddenChar decode_char(const std::string& s, std::size_t i) {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  HiddenChar h{i, 1, b(i)};
  std::size_t n = 0;
  std::uint32_t c = 0;
  if (b(i) >= 0xc2 && b(i) <= 0xdf) {
    n = 2;
    c = b(i) & 0x1fu;
  } else if (b(i) >= 0xe0 && b(i) <= 0xef) {
    n = 3;
    c = b(i) & 0x0fu;
  } else if (b(i) >= 0xf0 && b(i) <= 0xf4) {
    n = 4;
    c = b(i) & 0x07u;
  }
  if (n == 0 || i + n > s.size()) return h;
  for (std::size_t k = 1; k < n; ++k) {
    if ((b(i + k) & 0xc0u) != 0x80u) return h;
    c = (c << 6) | (b(i + k) & 0x3fu);
  }
  return HiddenChar{i, n, c};
}

// The first hidden character of `s`, or length 0 when there is none.
inline HiddenChar find_hidden_char(const std::string& s) {
  for (std::size_t i = 0; i < s.size();) {
    const HiddenChar h = decode_char(s, i);
    if (is_hidden_code(h.code)) return h;
    i += h.length;
  }
  return HiddenChar{s.size(), 0, 0};
}

// "U+202E" / "0x0a": how a message names a hidden character.
inline std::string show_code(std::uint32_t c) {
  char s[16];
  if (c < 0x80)
    std::snprintf(s, sizeof s, "0x%02x", static_cast<unsigned>(c));
  else
    std::snprintf(s, sizeof s, "U+%04X", static_cast<unsigned>(c));
  return s;
}

// `s` with every hidden character shown as \xNN (C0, DEL, bytes that are not UTF-8) or \u{XXXX} (the others),
// safe to print.
inline std::string show_hidden(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size();) {
    const HiddenChar h = decode_char(s, i);
    // A byte that starts no valid UTF-8 sequence (decode_char's one byte of value >= 0x80) is shown as
    // \xNN too: a terminal would take it for part of a character.
    if (is_hidden_code(h.code) || (h.length == 1 && h.code >= 0x80)) {
      char esc[16];
      if (h.code < 0x80 || h.length == 1)
        std::snprintf(esc, sizeof esc, "\\x%02x", static_cast<unsigned>(h.code));
      else
        std::snprintf(esc, sizeof esc, "\\u{%04X}", static_cast<unsigned>(h.code));
      out += esc;
    } else {
      out.append(s, i, h.length);
    }
    i += h.length;
  }
  return out;
}

// How many bytes of an input value a message quotes (show_value).
inline constexpr std::size_t kShownValueBytes = 60;

// An input value quoted in a message (a number as written, an option's value, a cell or line of a file, a
// scene string): show_hidden of its first `max_bytes` bytes (cut at a character boundary), then
// "…(N bytes)" when it is longer, so a 100,000-digit number makes a one-line message, not a 100 KB
// one. File names are not values: they are shown whole (show_hidden).
inline std::string show_value(const std::string& s, std::size_t max_bytes = kShownValueBytes) {
  if (s.size() <= max_bytes) return show_hidden(s);
  std::size_t cut = 0;
  for (std::size_t i = 0; i < s.size();) {
    const HiddenChar h = decode_char(s, i);
    if (i + h.length > max_bytes) break;
    i += h.length;
    cut = i;
  }
  return show_hidden(s.substr(0, cut)) + "\xe2\x80\xa6(" + std::to_string(s.size()) + " bytes)";
}

}  // namespace loom
