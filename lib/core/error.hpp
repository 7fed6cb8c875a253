#pragma once
// Errors in three tiers (STYLE.md): bad input is an InputError thrown at load with a message that
// names the file and the line, key or element; numerical trouble at run time is counted as a
// warning with a defined recovery; impossible states are assertions.
#include <stdexcept>
#include <string>
#include <string_view>

namespace ebh {

/// The length of the valid UTF-8 sequence that starts at text[i] (1 for ASCII), or 0 when the byte
/// there does not start one. Valid as RFC 3629 has it: no overlong form (e0 80 af for '/'), no
/// UTF-16 surrogate (ed a0 80), nothing past U+10FFFF (f4 90 80 80), which JSON parsers refuse.
inline std::size_t utf8_sequence_length(std::string_view text, std::size_t i) {
  const auto* s = reinterpret_cast<const unsigned char*>(text.data());
  const unsigned char c = s[i];
  const std::size_t len = c < 0x80 ? 1 : (c >= 0xc2 && c <= 0xdf) ? 2 : (c >= 0xe0 && c <= 0xef) ? 3
                          : (c >= 0xf0 && c <= 0xf4) ? 4 : 0;
  if (len == 0 || i + len > text.size()) return 0;
  for (std::size_t k = 1; k < len; ++k)
    if ((s[i + k] & 0xc0) != 0x80) return 0;
  // The second byte's range after the lead bytes that allow less than 80..bf.
  const unsigned char b = len > 1 ? s[i + 1] : 0;
  if ((c == 0xe0 && b < 0xa0) || (c == 0xed && b > 0x9f) || (c == 0xf0 && b < 0x90) || (c == 0xf4 && b > 0x8f)) return 0;
  return len;
}

/// The offset of the first byte of `text` that is not valid UTF-8, or npos.
inline std::size_t first_invalid_utf8(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t len = utf8_sequence_length(text, i);
    if (len == 0) return i;
    i += len;
  }
  return std::string_view::npos;
}

/// Whether `text` holds an ASCII control character (below 0x20, or DEL): a line break or a tab in
/// a name, which would split or shift every line that prints it.
inline bool has_control_character(std::string_view text) {
  for (const char c : text)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return true;
  return false;
}

/// Whether the valid UTF-8 sequence of `len` bytes at text[i] is a control character that changes
/// how a line reads rather than showing as text: a C1 control (U+0080..U+009F), a line or
/// paragraph separator (U+2028, U+2029: a line break to some viewers), a bidirectional mark or
/// override (U+200E, U+200F, U+202A..U+202E, U+2066..U+2069: "abc.h5" shown as "5h.cba").
inline bool is_layout_control(std::string_view text, std::size_t i, std::size_t len) {
  const auto* s = reinterpret_cast<const unsigned char*>(text.data()) + i;
  if (len == 2) return s[0] == 0xc2 && s[1] <= 0x9f;
  if (len != 3 || s[0] != 0xe2) return false;
  return (s[1] == 0x80 && (s[2] == 0x8e || s[2] == 0x8f || (s[2] >= 0xa8 && s[2] <= 0xae))) ||
         (s[1] == 0x81 && s[2] >= 0xa6 && s[2] <= 0xa9);
}

/// The first byte of `text` that is not UTF-8 (first_invalid_utf8) as "0xNN", for messages that
/// refuse it; "" when all of `text` is UTF-8.
inline std::string first_invalid_utf8_byte(std::string_view text) {
  const std::size_t bad = first_invalid_utf8(text);
  if (bad == std::string_view::npos) return "";
  static constexpr char kHex[] = "0123456789abcdef";
  const auto c = static_cast<unsigned char>(text[bad]);
  return std::string("0x") + kHex[c >> 4] + kHex[c & 0xf];
}

/// `text` with every byte that a terminal would not show as text written as \xNN: control
/// bytes (newlines included, so a message stays one line), the bytes of a layout control
/// (is_layout_control: U+2028, a right-to-left override) and bytes that are not part of valid
/// UTF-8. Printable ASCII and other valid UTF-8 (a file name in any language) are kept. Messages
/// quote file content ("'...' is not a number"): a binary file must not write raw bytes to a terminal.
inline std::string escape_unprintable(std::string_view text) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  const auto* s = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t n = text.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned char c = s[i];
    const std::size_t len = utf8_sequence_length(text, i);
    const bool shown = len == 1 ? c >= 0x20 && c != 0x7f : len > 1 && !is_layout_control(text, i, len);
    if (shown) {
      out.append(text.substr(i, len));
      i += len;
      continue;
    }
    // A byte that is no text, or each byte of a layout control.
    for (const std::size_t end = i + (len > 1 ? len : 1); i < end; ++i) {
      out += "\\x";
      out += kHex[s[i] >> 4];
      out += kHex[s[i] & 0xf];
    }
  }
  return out;
}

/// A token of a file quoted in a message: whole up to `max` bytes, else its first `max` and how
/// long it is ("1111...1 (200000000 bytes)"), so that a field of a broken file does not make a
/// message of megabytes.
inline std::string clipped(std::string_view token, std::size_t max = 40) {
  if (token.size() <= max) return std::string(token);
  return std::string(token.substr(0, max)) + "... (" + std::to_string(token.size()) + " bytes)";
}

/// Bad user input (a file, an option). what() is one line: "FILE:LINE: what is wrong" or
/// "FILE: key 'a.b': what is wrong", with non-printable bytes escaped (escape_unprintable()). Tools print it
/// and exit non-zero.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(escape_unprintable(what)) {}
  explicit InputError(const char* what) : InputError(std::string(what)) {}
};

/// A run that cannot go on because its numbers did (a non-finite or diverging state). what() is
/// one line naming where (tick, step) and the worst element; tools print it and exit with 4.
class NumericalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace ebh
