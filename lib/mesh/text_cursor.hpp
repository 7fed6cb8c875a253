#pragma once
// A line-aware cursor over a whole text file held in memory: the mesh readers' tokenizer.
// Internal to lib/mesh (not for other concepts). It never trusts the file: every number is
// range-checked, tokens never run past the end of the buffer, and every error is an InputError
// with one line "FILE:LINE: what". '\r' counts as white space, so CRLF files read like LF ones; a
// UTF-8 byte-order mark at the start (what some Windows tools write) is skipped.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <string_view>

#include "core/error.hpp"

namespace ebh::detail {

/// `file` opened to read (binary). Throws InputError "FILE: ..." for an unfinished output
/// (*.ebh-partial), a folder, or a file that cannot be opened ("cannot open file: " and the reason,
/// strerror's: "No such file or directory", "Permission denied").
std::ifstream open_input_file(const std::filesystem::path& file);

/// Reads a whole file into memory. Throws InputError as open_input_file, and "FILE: cannot read
/// file" where reading fails.
std::string read_file_bytes(const std::filesystem::path& file);

/// Renders an untrusted token for an error message: at most 40 characters, control and
/// non-ASCII bytes as \xNN, so that the message stays one printable line.
std::string printable(std::string_view token);

class TextCursor {
 public:
  /// A cursor over `text`, whose first line is the file's line `first_line` (a part of a file).
  TextCursor(const std::filesystem::path& file, std::string_view text, long long first_line = 1)
      : file_(file), text_(text), pos_(text.starts_with("\xEF\xBB\xBF") ? 3 : 0), line_(first_line) {}

  /// 1-based number of the line the cursor is on.
  long long line() const { return line_; }
  /// The cursor's byte offset in the text, and a jump to another (within binary data, whose line
  /// ends are not counted: a reader that names lines in it names the line where it starts).
  std::size_t position() const { return pos_; }
  void jump_to(std::size_t pos) { pos_ = std::min(pos, text_.size()); }
  /// Moves forward to `pos` past a block of binary data, counting the bytes in it that are line
  /// feeds (an int 10, a float's byte 0x0a) as line ends: the lines after it are numbered as a text
  /// editor or `grep -an` numbers them.
  void pass_to(std::size_t pos) {
    pos = std::min(pos, text_.size());
    if (pos <= pos_) return;
    line_ += std::count(text_.begin() + static_cast<std::ptrdiff_t>(pos_), text_.begin() + static_cast<std::ptrdiff_t>(pos), '\n');
    pos_ = pos;
  }
  /// Bytes left after the cursor: an upper bound on how many records the rest can hold.
  std::size_t remaining() const { return text_.size() - pos_; }
  bool at_end() const { return pos_ >= text_.size(); }

  /// True when only white space is left on the current line.
  bool at_eol() {
    skip_blanks();
    return pos_ >= text_.size() || text_[pos_] == '\n';
  }

  /// The next white-space separated token on the current line; empty at the end of the line.
  std::string_view token() {
    skip_blanks();
    std::size_t start = pos_;
    while (pos_ < text_.size() && !is_blank(text_[pos_]) && text_[pos_] != '\n') ++pos_;
    return text_.substr(start, pos_ - start);
  }

  /// The rest of the current line with surrounding white space removed (the cursor stays on it).
  std::string_view rest_of_line() {
    skip_blanks();
    std::size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    std::size_t end = pos_;
    while (end > start && is_blank(text_[end - 1])) --end;
    return text_.substr(start, end - start);
  }

  /// The next token of the free-form text of a format whose values run over lines (Medit, TetGen):
  /// blank lines and comments from `#` to the line's end are skipped; empty at the end of the file.
  std::string_view word() {
    while (skip_empty_lines()) {
      skip_blanks();
      if (text_[pos_] != '#') return token();
      next_line();
    }
    return {};
  }

  /// Moves to the start of the next line (whatever is left on this one is skipped).
  void next_line() {
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    if (pos_ < text_.size()) {
      ++pos_;
      ++line_;
    }
  }

  /// Skips lines holding only white space. Returns false at the end of the file.
  bool skip_empty_lines() {
    while (true) {
      if (!at_eol()) return true;
      if (pos_ >= text_.size()) return false;
      next_line();
    }
  }

  /// Moves to the next line, requiring that nothing but white space is left on this one.
  void end_line(const std::string& context) {
    if (!at_eol()) fail("unexpected extra value '" + printable(token()) + "'" + context);
    next_line();
  }

  /// Parses the next token as an integer in [lo, hi]; `what` names it in errors.
  long long integer(const char* what, long long lo, long long hi, const std::string& context = {}) {
    return to_integer(token(), what, lo, hi, context);
  }
  /// Parses the next token as a finite real number (`finite` false: NaN and infinities too, for
  /// values a reader checks itself, naming more than a line can).
  double real(const char* what, const std::string& context = {}, bool finite = true) {
    return to_real(token(), what, context, finite);
  }

  /// Token `t` as an integer in [lo, hi] (integer() on a token from elsewhere, e.g. word()).
  long long to_integer(std::string_view t, const char* what, long long lo, long long hi, const std::string& context = {}) {
    if (t.empty()) fail(std::string("expected ") + what + ", found the end of the " + (at_end() ? "file" : "line") + context);
    long long v = 0;
    auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
    if (ec == std::errc::result_out_of_range || (ec == std::errc() && p == t.data() + t.size() && (v < lo || v > hi)))
      fail(std::string(what) + " " + printable(t) + " is out of range [" + std::to_string(lo) + ", " +
           std::to_string(hi) + "]" + context);
    if (ec != std::errc() || p != t.data() + t.size())
      fail(std::string("expected ") + what + " (an integer), got '" + printable(t) + "'" + context);
    return v;
  }

  /// Token `t` as a finite real number (`finite` false: as real()).
  double to_real(std::string_view t, const char* what, const std::string& context = {}, bool finite = true) {
    if (t.empty()) fail(std::string("expected ") + what + ", found the end of the " + (at_end() ? "file" : "line") + context);
    const char* b = t.data();
    if (*b == '+' && t.size() > 1) ++b;  // from_chars rejects a leading '+', C's strtod accepts it
    double v = 0;
    auto [p, ec] = std::from_chars(b, t.data() + t.size(), v);
    if (ec == std::errc::result_out_of_range || (ec == std::errc() && p == t.data() + t.size() && finite && !std::isfinite(v)))
      fail(std::string(what) + " '" + printable(t) + "' is not a finite number" + context);
    if (ec != std::errc() || p != t.data() + t.size())
      fail(std::string("expected ") + what + " (a number), got '" + printable(t) + "'" + context);
    return v;
  }

  [[noreturn]] void fail(const std::string& what) const { fail_at(line_, what); }
  [[noreturn]] void fail_at(long long line, const std::string& what) const {
    throw InputError(file_.string() + ":" + std::to_string(line) + ": " + what);
  }

 private:
  static bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }
  void skip_blanks() {
    while (pos_ < text_.size() && is_blank(text_[pos_])) ++pos_;
  }

  std::filesystem::path file_;
  std::string_view text_;
  std::size_t pos_ = 0;
  long long line_ = 1;
};

}  // namespace ebh::detail
