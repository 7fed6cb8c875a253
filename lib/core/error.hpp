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

/// `text` with every byte that a terminal would not show as text written as \xNN: control
/// bytes (newlines included, so a message stays one line) and bytes that are not part of valid
/// UTF-8. Printable ASCII and valid UTF-8 (a file name in any language) are kept. Messages quote
/// file content ("'...' is not a number"): a binary file must not write raw bytes to a terminal.
inline std::string escape_unprintable(std::string_view text) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  const auto* s = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t n = text.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned char c = s[i];
    const std::size_t len = utf8_sequence_length(text, i);
    const bool ok = len > 1 || (len == 1 && c >= 0x20 && c != 0x7f);
    if (ok) {
      out.append(text.substr(i, len));
      i += len;
    } else {
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 0xf];
      i += 1;
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
