#pragma once
// Characters of input text (scene strings, file names, quoted file lines) that must never reach a terminal
// or an output file as they are: C0 controls and DEL (a newline, an escape, a NUL), C1 controls
// (U+0080-U+009F) and the invisible format controls that reorder or hide text (the Unicode bidirectional
// controls U+061C, U+200E, U+200F, U+202A-U+202E, U+2066-U+2069, the zero-width characters U+200B-U+200D,
// U+2060-U+2064 and U+FEFF). Text is UTF-8; a byte that does not start a valid UTF-8 sequence is taken as is.
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
  return c < 0x20 || c == 0x7f || (c >= 0x80 && c <= 0x9f) || c == 0x061c || (c >= 0x200b && c <= 0x200f) ||
         (c >= 0x202a && c <= 0x202e) || (c >= 0x2060 && c <= 0x2064) || (c >= 0x2066 && c <= 0x2069) ||
         c == 0xfeff;
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

// `s` with every hidden character shown as \xNN (C0, DEL) or \u{XXXX} (the others), safe to print.
inline std::string show_hidden(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size();) {
    const HiddenChar h = decode_char(s, i);
    if (is_hidden_code(h.code)) {
      char esc[16];
      if (h.code < 0x80)
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
