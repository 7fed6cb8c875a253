#include "io/import.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <tuple>
#include <utility>

#include "core/error.hpp"
#include "core/file_names.hpp"
#include "core/number_text.hpp"
#include "core/units.hpp"
#include "math/rotvec_input.hpp"
#include "io/paths.hpp"
#include "io/rosbag.hpp"

namespace ebh {
namespace {

std::string trim(const std::string& s) {
  std::size_t a = s.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return "";
  std::size_t b = s.find_last_not_of(" \t\r\n");
  return s.substr(a, b - a + 1);
}

// Splits on commas (an option's list of numbers).
std::vector<std::string> split_commas(const std::string& s) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    std::size_t c = s.find(',', start);
    out.push_back(trim(s.substr(start, c == std::string::npos ? std::string::npos : c - start)));
    if (c == std::string::npos) break;
    start = c + 1;
  }
  return out;
}

bool blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

// A CSV line's fields: separated by a comma (blanks around it belong to the separator) or by a run
// of spaces or tabs. An empty field between two commas is kept (and refused as a number), so a
// missing cell is named rather than shifting the columns after it. A field in double quotes
// (RFC 4180, as Python's csv module and spreadsheets may write every field) is read without them.
std::vector<std::string> split_csv_quoted(const std::string& s);
std::vector<std::string> split_csv(const std::string& s) {
  std::vector<std::string> out = split_csv_quoted(s);
  for (std::string& f : out)
    if (f.size() >= 2 && f.front() == '"' && f.back() == '"') f = f.substr(1, f.size() - 2);
  return out;
}

std::vector<std::string> split_csv_quoted(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  std::size_t i = 0;
  const std::size_t n = s.size();
  while (i < n) {
    if (s[i] == '"' && cur.empty()) {  // a quoted field: separators inside it are its own, "" a quote
      cur += s[i++];
      while (i < n && !(s[i] == '"' && (i + 1 == n || s[i + 1] != '"'))) {
        if (s[i] == '"') ++i;
        cur += s[i++];
      }
      if (i < n) cur += s[i++];
      continue;
    }
    if (s[i] != ',' && !blank(s[i])) {
      cur += s[i++];
      continue;
    }
    while (i < n && blank(s[i])) ++i;
    if (i < n && s[i] == ',') ++i;
    while (i < n && blank(s[i])) ++i;
    out.push_back(cur);
    cur.clear();
    if (i == n) out.push_back("");  // a separator at the end: an empty last field
  }
  if (!cur.empty() || out.empty()) out.push_back(cur);
  return out;
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

struct Line {
  std::size_t number;  // 1-based
  std::string text;    // comment stripped, trimmed
};

/// What the readers leave out of a log, for ImportReport.
struct LeftOut {
  std::size_t cut_line = 0;         ///< the last line, without a line end (0: none)
  std::size_t duplicate_rows = 0;   ///< rows equal to the row before them, time included
  std::size_t first_duplicate = 0;  ///< the line of the first
};

std::string at(const std::string& path, std::size_t line) { return path + ":" + std::to_string(line); }

// A byte no text log holds: a control character other than tab, carriage return, form feed.
bool binary_byte(unsigned char c) { return (c < 0x20 && c != '\t' && c != '\r' && c != '\f') || c == 0x7f; }

// One pass over a text log's lines (for_each_line). A last line without a line end (a logger
// stopped while writing it: its last number may be cut, 0.0452001 read as 0.04) is not passed to
// `each`; its number goes to `cut_line`.
template <class F>
void for_each_text_line(const std::string& path, F&& each, std::size_t* cut_line = nullptr) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open: " + std::strerror(errno));
  std::string s;
  std::size_t n = 0;
  while (std::getline(in, s)) {
    ++n;
    const bool cut = in.eof();
    // A byte-order mark (spreadsheets write one): UTF-8's is dropped; UTF-16 is not a text log here.
    if (n == 1 && s.starts_with("\xEF\xBB\xBF")) s.erase(0, 3);
    if (n == 1 && (s.starts_with("\xFF\xFE") || s.starts_with("\xFE\xFF")))
      throw InputError(at(path, n) + ": UTF-16 text (a byte-order mark): save the log as UTF-8 or ASCII");
    for (unsigned char c : s)
      if (binary_byte(c)) {
        char code[8];
        std::snprintf(code, sizeof code, "0x%02x", c);
        throw InputError(at(path, n) + ": byte " + code + ": not a text file (expected an OpenHaptics or CSV log)");
      }
    // Lines ended by a carriage return alone (classic Mac OS, Excel's "CSV (Macintosh)"): the
    // whole log reads as one line.
    if (const auto cr = s.find('\r'); cr != std::string::npos && cr + 1 < s.size())
      throw InputError(at(path, n) + ": lines end in a carriage return alone (classic Mac line ends): save the log "
                                     "with LF or CRLF line ends");
    if (auto h = s.find('#'); h != std::string::npos) s.erase(h);
    s = trim(s);
    if (s.empty()) continue;
    if (cut && cut_line) *cut_line = n;
    else each(Line{n, s});
  }
}

// Calls `each(line)` for every line that is not blank once its comment is stripped, in order,
// after a text log's checks (byte-order mark, control bytes). It streams: memory holds one line,
// not the log (a 12-million-line log is read in the memory of its samples alone). The checks run
// over the whole file first, so a binary file is named as such rather than by its first line's
// fields.
template <class F>
void for_each_line(const std::string& path, LeftOut& left_out, F&& each) {
  check_input_file(path);
  for_each_text_line(path, [](const Line&) {});
  for_each_text_line(path, each, &left_out.cut_line);
}

// A log is read up to the samples a recording may hold (kMaxRecordingSamples, docs/FORMATS.md,
// Limits): one sample more stops the import at its line, before memory grows with the log.
void check_sample_limit(const Recording& rec, std::size_t limit, const std::string& where) {
  if (rec.t.size() >= limit)
    throw InputError(where + ": more than " + std::to_string(limit) +
                     " samples, the limit of a recording (2.8 h at 1 kHz): import it a window at a time (--start S "
                     "--duration S)");
}

/// The window of a log to import (ImportOptions::start_s, duration_s) over its samples' times in
/// seconds: `keeps(t)` for each sample in file order, the first one's time the window's origin.
struct LogWindow {
  double start = 0;
  std::optional<double> duration;
  std::optional<double> origin;
  double span = 0;     // the last sample's time from the origin
  bool ended = false;  // a sample past the window was seen: the lines after it are not read
  bool keeps(double t) {
    if (!origin) origin = t;
    const double from = t - *origin;
    span = from;
    ended = duration && from > start + *duration;
    return from >= start && !ended;
  }
  bool whole() const { return start == 0 && !duration; }
};

// A row of a log whose header is separated by tabs or spaces, with a comma between two digits: a
// number written with a decimal comma (a spreadsheet in a locale that writes 0,5), which the
// comma splits into two fields.
std::string decimal_comma_hint(const std::string& header, const std::string& row) {
  if (header.find(',') != std::string::npos) return "";
  for (std::size_t i = 1; i + 1 < row.size(); ++i)
    if (row[i] == ',' && std::isdigit(static_cast<unsigned char>(row[i - 1])) &&
        std::isdigit(static_cast<unsigned char>(row[i + 1])))
      return " (numbers with a decimal comma? write them with a decimal point, 0.5)";
  return "";
}

double to_number(const std::string& tok, const std::string& where, const std::string& field) {
  const char* b = tok.c_str();
  char* e = nullptr;
  errno = 0;
  double v = std::strtod(b, &e);
  // strtod also reads hexadecimal ("0x1p3"), which no log writes and `--set` refuses.
  if (tok.empty() || e != b + tok.size() || tok.find_first_of("xX") != std::string::npos) {
    const bool comma = tok.find(',') != std::string::npos && e > b && *e == ',';
    throw InputError(where + ": " + field + ": '" + clipped(tok) + "' is not a number" +
                     (comma ? " (a decimal comma? write numbers with a decimal point, 0.5)" : ""));
  }
  // ERANGE: beyond a double (inf), or below its smallest normal (a subnormal or 0, a fine value).
  if (errno == ERANGE && std::fabs(v) > 1)
    throw InputError(where + ": " + field + ": '" + clipped(tok) + "' is beyond the range of a number");
  return v;
}

int to_int(const std::string& tok, const std::string& where, const std::string& field, int lo, int hi) {
  double v = to_number(tok, where, field);
  if (v != std::floor(v) || v < lo || v > hi)
    throw InputError(where + ": " + field + ": '" + tok + "' is not an integer in " + std::to_string(lo) + ".." +
                     std::to_string(hi));
  return static_cast<int>(v);
}

// Shepperd's method: the quaternion of a proper rotation matrix.
Quatd quat_from_matrix(const Eigen::Matrix3d& R) {
  double tr = R.trace();
  Quatd q;
  if (tr > 0) {
    double s = 2.0 * std::sqrt(tr + 1.0);
    q = {0.25 * s, (R(2, 1) - R(1, 2)) / s, (R(0, 2) - R(2, 0)) / s, (R(1, 0) - R(0, 1)) / s};
  } else if (R(0, 0) > R(1, 1) && R(0, 0) > R(2, 2)) {
    double s = 2.0 * std::sqrt(1.0 + R(0, 0) - R(1, 1) - R(2, 2));
    q = {(R(2, 1) - R(1, 2)) / s, 0.25 * s, (R(0, 1) + R(1, 0)) / s, (R(0, 2) + R(2, 0)) / s};
  } else if (R(1, 1) > R(2, 2)) {
    double s = 2.0 * std::sqrt(1.0 + R(1, 1) - R(0, 0) - R(2, 2));
    q = {(R(0, 2) - R(2, 0)) / s, (R(0, 1) + R(1, 0)) / s, 0.25 * s, (R(1, 2) + R(2, 1)) / s};
  } else {
    double s = 2.0 * std::sqrt(1.0 + R(2, 2) - R(0, 0) - R(1, 1));
    q = {(R(1, 0) - R(0, 1)) / s, (R(0, 2) + R(2, 0)) / s, (R(1, 2) + R(2, 1)) / s, 0.25 * s};
  }
  return normalized(q);
}

// The nearest rotation (polar factor via SVD) of a logged 3x3 block; rejects reflections and
// matrices farther than kRotationTolerance (Frobenius) from it.
Quatd orthonormalised(const Eigen::Matrix3d& M, const std::string& where) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) throw InputError(where + ": the rotation part is a reflection (determinant < 0)");
  double off = (M - R).norm();
  if (!(off <= kRotationTolerance))
    throw InputError(where + ": the rotation part is not a rotation (Frobenius distance " + std::to_string(off) +
                     " to the nearest one, tolerance " + std::to_string(kRotationTolerance) + ")");
  return quat_from_matrix(R);
}

// The first number of an OpenHaptics line written with a decimal comma ("14,5"), "" when there is
// none: a comma between two digits, in a line whose fields are separated by blanks (one whose
// fields a comma separates, "1,0,0", has commas between digits too, and writes its decimals with
// points) or in which no number is written with a point ("0,25 0,5 ...").
std::string decimal_comma_number(const std::string& t) {
  const auto digit = [&t](std::size_t i) { return std::isdigit(static_cast<unsigned char>(t[i])) != 0; };
  const auto blank = [&t](std::size_t i) { return t[i] == ' ' || t[i] == '\t'; };
  auto between_digits = [&](char mark) {
    for (std::size_t i = 1; i + 1 < t.size(); ++i)
      if (t[i] == mark && digit(i - 1) && digit(i + 1)) return i;
    return std::string::npos;
  };
  const std::size_t comma = between_digits(',');
  if (comma == std::string::npos) return "";
  // A run of blanks with no comma beside it separates two fields.
  bool blank_separated = false;
  for (std::size_t i = 0; i < t.size() && !blank_separated;) {
    if (!blank(i)) {
      ++i;
      continue;
    }
    const std::size_t b = i;
    while (i < t.size() && blank(i)) ++i;
    blank_separated = b > 0 && i < t.size() && t[b - 1] != ',' && t[i] != ',';
  }
  if (!blank_separated && between_digits('.') != std::string::npos) return "";
  // The number around the comma: its sign, digits and point before, its digits after.
  const auto part = [](char c) {
    return std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '+';
  };
  std::size_t b = comma, e = comma + 1;
  while (b > 0 && part(t[b - 1])) --b;
  while (e < t.size() && digit(e)) ++e;
  return t.substr(b, e - b);
}

// The hint for a number written with a decimal comma ("14,5"; none for ""): " (decimal commas?
// write the numbers with a '.': 14.5, not 14,5)", naming `line` where it is another line's.
std::string comma_number_hint(const std::string& number, const std::string& line = "") {
  if (number.empty()) return "";
  std::string point = number;
  point[point.find(',')] = '.';
  return " (decimal commas? write the numbers with a '.': " + point + ", not " + number +
         (line.empty() ? "" : " in " + line) + ")";
}

void read_openhaptics(const std::string& path, double unit, double rate, std::size_t limit, LogWindow& window,
                      Recording& rec, std::vector<std::size_t>& line_of, LeftOut& left_out) {
  std::size_t fields = 0, fields_line = 0;  // the first sample's field count, and its line
  std::string fields_comma;                 // a number of the first sample's written with a decimal comma
  std::size_t samples = 0;                  // the log's, the window's and before it
  for_each_line(path, left_out, [&](const Line& l) {
    if (window.ended) return;
    const std::string where = at(path, l.number);
    const double t = static_cast<double>(samples) / rate;
    if (!window.keeps(t)) {
      ++samples;
      return;
    }
    check_sample_limit(rec, limit, where);
    // Separated as a CSV log's fields: an empty field (two commas in a row) is named, not skipped,
    // so a missing value does not shift the fields after it (the jaw into a button's place).
    auto tok = split_csv_quoted(l.text);
    // A header naming columns: a CSV log read as OpenHaptics (the format follows the extension).
    bool words = false;
    if (!tok.empty() && !tok[0].empty()) {
      char* end = nullptr;
      std::strtod(tok[0].c_str(), &end);
      words = end == tok[0].c_str();
    }
    if (!(words && tok.size() < 17))
      for (std::size_t k = 0; k < tok.size(); ++k)
        if (tok[k].empty())
          throw InputError(where + ": field " + std::to_string(k + 1) +
                           (k < 16    ? " (element " + std::to_string(k) + ")"
                            : k == 16 ? std::string(" (the jaw)")
                            : k < 25  ? " (button " + std::to_string(k - 17) + ")"
                                      : std::string()) +
                           " is empty: " +
                           (k + 1 == tok.size() ? "a separator ends the line"
                                                : "two separators with nothing between them") +
                           " (a missing value?)");
    if (tok.size() < 17) {
      const bool semicolons = l.text.find(';') != std::string::npos;
      throw InputError(where + ": " + std::to_string(tok.size()) +
                       " fields, expected 16 transform elements, the jaw and button states" +
                       (words        ? " (read as an OpenHaptics log; a CSV log with a header needs --format csv)"
                        : semicolons ? " (fields are separated by spaces, tabs or commas, not ';')"
                                     : ""));
    }
    // "0,25 0,5 ...": numbers written with decimal commas split in two at the comma, and every
    // field after the first such number moves; in one line of the log (a value typed in by hand)
    // that line's fields or the first sample's differ.
    const std::string comma_number = decimal_comma_number(l.text);
    const std::string commas = comma_number_hint(comma_number);
    if (tok.size() > 17 + 8) throw InputError(where + ": more than 8 button states" + commas);
    // Every sample has the fields of the first: one missing or added shifts the rest (element 14
    // missing read the jaw as element 15 and a button as the jaw, a one-sample grasp).
    if (fields == 0) {
      fields = tok.size();
      fields_line = l.number;
      fields_comma = comma_number;
    } else if (tok.size() != fields) {
      const std::string first_commas =
          commas.empty() ? comma_number_hint(fields_comma, "line " + std::to_string(fields_line)) : commas;
      throw InputError(where + ": " + std::to_string(tok.size()) + " fields, but line " + std::to_string(fields_line) +
                       ", the first sample, has " + std::to_string(fields) +
                       (first_commas.empty() ? ": a value missing or added? (every line holds the 16 elements, the jaw "
                                               "and the same button states)"
                                             : first_commas));
    }
    double m[16];
    for (int k = 0; k < 16; ++k) m[k] = to_number(tok[k], where, "element " + std::to_string(k));
    for (int k = 0; k < 16; ++k)
      if (!std::isfinite(m[k])) throw InputError(where + ": element " + std::to_string(k) + " is NaN or Inf");
    // Column-major: element (r, c) = m[4 c + r]; the bottom row must be (0, 0, 0, 1).
    if (std::abs(m[3]) > 1e-6 || std::abs(m[7]) > 1e-6 || std::abs(m[11]) > 1e-6 || std::abs(m[15] - 1) > 1e-6) {
      // Row-major (the matrix written row by row): the translation in elements 3, 7, 11, the
      // bottom row (0, 0, 0, 1) in elements 12-15.
      const auto zero = [](double v) { return std::abs(v) <= 1e-6; };
      const bool row_major = zero(m[12]) && zero(m[13]) && zero(m[14]) && zero(m[15] - 1) &&
                             !(zero(m[3]) && zero(m[7]) && zero(m[11]));
      // Shifted by one, the bottom row is at elements 4, 8, 12, 16: a column before the matrix (a time).
      const bool shifted = !row_major && tok.size() >= 17 && zero(to_number(tok[4], where, "element 4")) &&
                           zero(to_number(tok[8], where, "element 8")) &&
                           zero(to_number(tok[12], where, "element 12")) &&
                           zero(to_number(tok[16], where, "element 16") - 1);
      std::string why = "is it row-major?";
      if (!commas.empty())
        why = commas.substr(2, commas.size() - 3);
      else if (row_major)
        why = "row-major? elements 3, 7, 11 hold (" + num(m[3]) + ", " + num(m[7]) + ", " + num(m[11]) +
              "), a translation, and 12, 13, 14, 15 are 0, 0, 0, 1: the matrix written row by row; an OpenHaptics " +
              "log holds it column-major, as hdGetDoublev(HD_CURRENT_TRANSFORM) returns it: write its transpose";
      else if (shifted)
        why = "they are one field later: a column before the 16 elements, a time? An OpenHaptics log holds only the "
              "matrix, the jaw and the buttons; a log with times is a CSV log (docs/FORMATS.md)";
      throw InputError(where + ": not a homogeneous transform (elements 3, 7, 11, 15 must be 0, 0, 0, 1; " + why + ")");
    }
    Eigen::Matrix3d M;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) M(r, c) = m[4 * c + r];
    rec.orientation.push_back(orthonormalised(M, where));
    rec.position.push_back(Vec3d{m[12], m[13], m[14]} * unit);
    rec.jaw.push_back(to_number(tok[16], where, "jaw"));
    int mask = 0;
    // A state is 0 or 1: a sample counter or another column after the buttons would set a bit on
    // every sample, and a jaw written with a decimal comma ("0,75") a button of its decimals.
    for (std::size_t b = 17; b < tok.size(); ++b)
      if (to_int(tok[b], where, "button " + std::to_string(b - 17) + " (a state, 0 or 1; " +
                                    (commas.empty() ? "a counter or another column after the buttons?)"
                                                    : commas.substr(2)),
                 0, 1) != 0)
        mask |= 1 << (b - 17);
    rec.buttons.push_back(static_cast<std::uint8_t>(mask));
    rec.t.push_back(t);
    ++samples;
    line_of.push_back(l.number);
  });
}

// A column name another logger gives the samples' times (lower case).
/// A column of Euler angles or a rotation vector, which a CSV log cannot give (its orientation is
/// the quaternion): --skip-column would drop the tool's orientation without a word.
bool angle_name(const std::string& h) {
  for (const char* n : {"rx", "ry", "rz", "roll", "pitch", "yaw", "rotx", "roty", "rotz", "rot_x", "rot_y", "rot_z",
                        "ax", "ay", "az", "alpha", "beta", "gamma", "azimuth", "elevation"})
    if (h == n) return true;
  return false;
}

bool time_name(const std::string& h) {
  for (const char* n : {"time", "times", "timestamp", "time_s", "t_s", "time(s)", "seconds", "sec", "stamp"})
    if (h == n) return true;
  return false;
}

/// The column a ROS CSV export names for ebh (`rostopic echo -p`, rosbag's bag_to_csv: a message's
/// fields as field.a.b): "t" for %time, x y z for a pose's position (a transform's translation), qx
/// qy qz qw for its orientation (rotation); "" for its other fields. `name` lower-cased.
std::string ros_column(const std::string& name) {
  if (name == "%time") return "t";
  for (const char* p : {".position.", ".translation."})
    for (const char* a : {"x", "y", "z"})
      if (name.ends_with(std::string(p) + a)) return a;
  for (const char* p : {".orientation.", ".rotation."})
    for (const char* a : {"x", "y", "z", "w"})
      if (name.ends_with(std::string(p) + a)) return std::string("q") + a;
  return "";
}

void read_csv(const std::string& path, double unit, double rate, double& time_unit, std::size_t limit, LogWindow& window,
              Recording& rec, std::vector<std::size_t>& line_of, bool& has_t, bool& has_jaw, LeftOut& left_out,
              const std::vector<std::string>& skip_columns, bool time_unit_given, std::string& layout_note) {
  std::size_t samples = 0;  // the log's, the window's and before it
  const std::vector<std::string> known{"t", "x", "y", "z", "qw", "qx", "qy", "qz", "jaw", "buttons"};
  std::map<std::string, std::size_t> col;
  std::vector<std::string> header;
  bool have_header = false;
  std::string header_text, previous;  // the header's text, the last data row's
  std::optional<double> last_t;       // the last data row's t (log unit)
  for_each_line(path, left_out, [&](const Line& l) {
    if (!have_header) {
      have_header = true;
      header_text = l.text;
      header = split_csv(l.text);
      // What a header line written by another tool may look like, named before "unknown column".
      const bool numbers = std::all_of(header.begin(), header.end(), [](const std::string& f) {
        char* e = nullptr;
        (void)std::strtod(f.c_str(), &e);
        return !f.empty() && *e == '\0';
      });
      if (numbers)
        throw InputError(at(path, l.number) + ": no header line: the first line that is not a comment holds numbers " +
                         (header.size() >= 17 && header.size() <= 25
                              ? "(" + std::to_string(header.size()) + " of them: an OpenHaptics log's 16 transform " +
                                    "elements, jaw and buttons? --format openhaptics reads it)"
                              : std::string("(a header commented out with '#', as numpy.savetxt writes it? write it as "
                                            "the first line without '#': t,x,y,z,qw,qx,qy,qz)")));
      for (const std::string& skip : skip_columns)
        if (std::find(header.begin(), header.end(), skip) == header.end())
          throw InputError(at(path, l.number) + ": --skip-column " + skip + ": the header has no such column");
      // A ROS export (its %time, its fields as field.*): its pose's columns read as ours, its
      // other fields left unread, its %time in nanoseconds unless --time-unit says otherwise.
      const bool ros = std::any_of(header.begin(), header.end(), [](const std::string& h) {
        return h == "%time" || h.starts_with("field.");
      });
      std::size_t ros_unread = 0;
      std::vector<std::string> ros_read;
      for (std::size_t i = 0; i < header.size(); ++i) {
        if (header[i].empty())
          throw InputError(at(path, l.number) + ": column " + std::to_string(i + 1) + " has no name" +
                           (i == 0 ? " (the index pandas writes? save with to_csv(..., index=False))" : ""));
        if (header[i].front() == '[' || header[i].front() == '(')
          throw InputError(at(path, l.number) + ": '" + clipped(header[i]) + "': units in the header are not read: name the " +
                           "columns t, x, y, z, ... and give the length unit with --unit (times are in seconds)");
        std::string h = header[i];
        std::transform(h.begin(), h.end(), h.begin(), [](unsigned char c) { return std::tolower(c); });
        if (std::find(skip_columns.begin(), skip_columns.end(), header[i]) != skip_columns.end()) continue;
        if (ros && std::find(known.begin(), known.end(), h) == known.end()) {
          const std::string ours = ros_column(h);
          if (ours.empty()) {
            ++ros_unread;
            continue;
          }
          ros_read.push_back(header[i] + " as " + ours + (h == "%time" && !time_unit_given ? " (nanoseconds)" : ""));
          h = ours;
        }
        if (std::find(known.begin(), known.end(), h) == known.end())
          throw InputError(at(path, l.number) + ": unknown column '" + clipped(header[i]) +
                           "' (known: t, x, y, z, qw, qx, qy, qz, jaw, buttons" +
                           (header[i].find(';') != std::string::npos
                                ? "; columns are separated by commas, spaces or tabs, not ';'"
                                : time_name(h) ? "; the samples' times? name the column t (seconds), which is read: "
                                                 "--skip-column would leave them unread and take --rate's"
                                : angle_name(h) ? "; angles of the tool's orientation? a CSV log gives it as the unit "
                                                  "quaternion qw, qx, qy, qz: convert Euler angles or a rotation vector "
                                                  "to it first (docs/OWN_DATA.md, \"CSV logs\")"
                                : header[i].size() > 40 ? "" : "; a column of other data: --skip-column " + header[i] + " leaves it unread") +
                           ")");
        if (!col.emplace(h, i).second)
          throw InputError(at(path, l.number) + ": column '" + clipped(h) + "' appears twice" +
                           (ros ? " (read as a ROS export: " + clipped(header[col.at(h)]) + " and " + clipped(header[i]) +
                                      " both give it; --skip-column one of them)"
                                : ""));
      }
      for (const char* req : {"x", "y", "z", "qw", "qx", "qy", "qz"})
        if (!col.count(req))
          throw InputError(at(path, l.number) + ": missing column '" + req + "'" +
                           (ros ? " (read as a ROS export: a pose's field.*.position.x .. z and field.*.orientation.x .. w, "
                                  "or a transform's translation and rotation)"
                                : ""));
      has_t = col.count("t") > 0;
      has_jaw = col.count("jaw") > 0;
      if (ros) {
        const bool stamped = has_t && header[col.at("t")] == "%time";
        if (stamped && !time_unit_given) time_unit = 1e-9;  // rostopic's clock
        std::string read;
        for (const std::string& r : ros_read) read += (read.empty() ? "" : ", ") + r;
        layout_note = "read as a ROS export: " + read + "; " + std::to_string(ros_unread) + " other field" +
                      (ros_unread == 1 ? "" : "s") + " left unread";
      }
      return;
    }
    if (window.ended) return;
    const std::string where = at(path, l.number);
    // A row written twice, its time included (a logger's retry): the same sample, left out.
    if (has_t && l.text == previous) {
      if (left_out.duplicate_rows++ == 0) left_out.first_duplicate = l.number;
      return;
    }
    previous = l.text;
    // Without times a row's time is its place: the window skips it unread.
    const double placed = static_cast<double>(samples) / rate;
    if (!has_t && !window.keeps(placed)) {
      ++samples;
      return;
    }
    auto tok = split_csv(l.text);
    if (tok.size() != header.size())
      throw InputError(where + ": " + std::to_string(tok.size()) + " fields, the header has " +
                       std::to_string(header.size()) + decimal_comma_hint(header_text, l.text) +
                       (std::count(l.text.begin(), l.text.end(), '"') % 2 != 0
                            ? std::string("; a quote (\") on the line is not closed, which makes the rest of it one field")
                            : std::string()));
    auto get = [&](const char* name) { return to_number(tok[col.at(name)], where, name); };
    const double t = has_t ? get("t") : placed;
    // Before the window's test, which a NaN would fail (the row left out unsaid) and an infinity
    // would pass as the log's origin or its end; so would a time before the first.
    if (!std::isfinite(t)) throw InputError(where + ": t is " + tok[col.at("t")] + ": a sample's time must be a finite number");
    if (has_t && last_t)
      if (const auto bad = time_defect(*last_t * time_unit, t * time_unit)) throw InputError(where + ": " + *bad);
    last_t = t;
    ++samples;
    if (has_t && !window.keeps(t * time_unit)) return;
    check_sample_limit(rec, limit, where);
    rec.t.push_back(t);
    rec.position.push_back(Vec3d{get("x"), get("y"), get("z")} * unit);
    rec.orientation.push_back(Quatd{get("qw"), get("qx"), get("qy"), get("qz")});
    rec.jaw.push_back(col.count("jaw") ? get("jaw") : 1.0);
    rec.buttons.push_back(
        col.count("buttons") ? static_cast<std::uint8_t>(to_int(tok[col.at("buttons")], where, "buttons", 0, 255)) : 0);
    line_of.push_back(l.number);
  });
  if (!have_header) throw InputError(path + ": empty log (expected a header line naming the columns)");
}

/// A ROS bag's pose topic (io/rosbag.hpp) as samples (line_of: the message's index in the
/// topic, from 1), positions times `unit`; the jaw from the jaw topic, if any (has_jaw).
/// What a bag's poses of a tf frame are: the transforms to it, and the links above it they were
/// composed with into the frame they are given in.
std::string frame_note(const BagContents& bag) {
  const BagLink& own = bag.links.back();
  std::string s = std::to_string(own.transforms) + " transforms " + own.parent + " -> " + own.child;
  if (bag.links.size() == 1) return s;
  s += ", composed with";
  for (std::size_t k = bag.links.size() - 1; k-- > 0;) {
    const BagLink& l = bag.links[k];
    s += std::string(k + 2 == bag.links.size() ? " " : ", ") + l.parent + " -> " + l.child + " (" +
         std::to_string(l.transforms) + ", " + (l.held ? "held" : "interpolated") + ")";
  }
  s += " into " + bag.frame_chain.front();
  if (bag.outside_links > 0)
    s += "; " + std::to_string(bag.outside_links) + " at times outside an interpolated link's transforms left out";
  return s;
}

/// Returns the bag's kind ("ROS 1 bag") and the pose topic read.
std::pair<std::string, std::string> read_bag(const std::string& path, double unit, const ImportOptions& opt,
                                             LogWindow& window, Recording& rec, std::vector<std::size_t>& line_of,
                                             bool& has_jaw, std::string& layout_note, std::size_t& cut_bytes) {
  if (!opt.jaw_joint.empty() && opt.jaw_topic.empty())
    throw InputError("--jaw-joint: " + path + ": the joint is of the jaw topic: give --jaw-topic too");
  if (!opt.root_frame.empty() && opt.frame.empty())
    throw InputError("--root-frame: " + path + ": the frame --frame's poses are given in: give --frame too");
  BagContents bag = read_rosbag(path, BagRequest{opt.topic, opt.jaw_topic, opt.frame, opt.jaw_joint, opt.button_topic, opt.root_frame});
  cut_bytes = bag.cut_bytes;
  has_jaw = !bag.jaw.empty();
  // The device's clock where every message carries it (a header stamp set), else the bag's.
  const auto stamped = [](const auto& messages) {
    return std::all_of(messages.begin(), messages.end(), [](const auto& m) { return m.t.stamp > 0; });
  };
  const bool stamps = stamped(bag.poses) && stamped(bag.jaw) && stamped(bag.buttons);
  const auto time = [stamps](const BagTimes& t) { return stamps ? t.stamp : t.record; };
  const auto by_time = [&](const auto& a, const auto& b) { return time(a.t) < time(b.t); };
  std::stable_sort(bag.jaw.begin(), bag.jaw.end(), by_time);
  std::stable_sort(bag.buttons.begin(), bag.buttons.end(), by_time);
  // The last jaw (button) message at or before the sample's time: its value holds until the next.
  std::size_t jaw_at = 0, button_at = 0;
  const auto hold = [&](const auto& messages, std::size_t& at, double t) {
    while (at + 1 < messages.size() && time(messages[at + 1].t) <= t) ++at;
  };
  for (std::size_t i = 0; i < bag.poses.size(); ++i) {
    const BagPose& m = bag.poses[i];
    const double t = time(m.t);
    if (!window.keeps(t)) {
      if (window.ended) break;
      continue;
    }
    check_sample_limit(rec, opt.max_samples, path + ": " + bag.pose_topic + " message " + std::to_string(i + 1));
    hold(bag.jaw, jaw_at, t);
    hold(bag.buttons, button_at, t);
    rec.t.push_back(t);
    rec.position.push_back(m.position * unit);
    rec.orientation.push_back(m.orientation);
    rec.jaw.push_back(has_jaw ? bag.jaw[jaw_at].value : 1.0);
    rec.buttons.push_back(bag.buttons.empty() ? 0 : bag.buttons[button_at].bits);
    line_of.push_back(i + 1);
  }
  const bool pose_headers = bag.pose_type.find("Stamped") != std::string::npos || !opt.frame.empty();
  const std::string why_record = stamps              ? ""
                                 : !pose_headers     ? " (" + bag.pose_type + " has no header)"
                                 : !stamped(bag.poses) ? " (a pose's header stamp is 0)"
                                 : !stamped(bag.jaw) ? " (the jaw's messages carry no stamp)"
                                                     : " (a button message's header stamp is 0)";
  const std::size_t messages = std::find_if(bag.topics.begin(), bag.topics.end(), [&](const BagTopic& t) {
                                 return t.name == bag.pose_topic;
                               })->messages;
  layout_note = "read as a " + bag.kind + ": topic " + bag.pose_topic + " (" + bag.pose_type + ", " +
                std::to_string(messages) + " messages" +
                (opt.frame.empty() ? std::string() : "; " + frame_note(bag)) +
                ")" +
                (has_jaw ? ", the jaw from " + opt.jaw_topic + (opt.jaw_joint.empty() ? "" : " joint " + opt.jaw_joint) +
                               " (" + bag.jaw_type + ", " +
                               std::to_string(bag.jaw.size()) + " messages; each pose takes the last at or before it)"
                         : std::string()) +
                (bag.buttons.empty() ? std::string()
                                     : ", the buttons from " + opt.button_topic + " (sensor_msgs/Joy, " +
                                           std::to_string(bag.buttons.size()) + " messages, held as the jaw's)") +
                "; times from " + (stamps ? "the messages' header stamps" : "the bag's record times" + why_record);
  return {bag.kind, bag.pose_topic};
}

// The time unit under which times read as seconds give `rate_hz` of a device (kDeviceRateLowHz ..
// kDeviceRateHighHz), with the rate it would be; nullptr when none does.
struct TimeUnit {
  const char* name = nullptr;  // nullptr: none
  const char* symbol = nullptr;
  double rate_hz = 0;
};
TimeUnit likely_time_unit(double rate_hz) {
  for (const auto& [name, symbol, per_second] : {std::tuple{"milliseconds", "ms", 1e3}, {"microseconds", "us", 1e6},
                                                 {"nanoseconds", "ns", 1e9}})
    if (rate_hz * per_second >= kDeviceRateLowHz && rate_hz * per_second <= kDeviceRateHighHz)
      return {name, symbol, rate_hz * per_second};
  return {};
}

// The rate a log's times (has_t) or --rate give, against a recording's limit (an error) and a
// device's rates (a warning, returned): times in ms make a rate 1000 times too low, in units
// smaller than seconds' one too high. Times whose rate is a device's in ms, us or ns are an error
// unless `unit_given` (--time-unit, or a bag's times, which are seconds): a recording at 1 Hz or
// 1e-6 Hz from a device log is never meant, and a script's `import && replay` would go on with it.
// `times`: what the log's times are called ("column t", a bag's "the messages' times").
std::string check_log_rate(const Recording& rec, bool has_t, bool unit_given, const std::string& path,
                           const std::string& times) {
  const std::string band = "a device logs at " + num(kDeviceRateLowHz) + " Hz to " + num(kDeviceRateHighHz / 1e3) + " kHz";
  const std::string span = num(rec.rate_hz) + " Hz (a median interval of " + num(1 / rec.rate_hz) + " s between " +
                           std::to_string(rec.size()) + " samples over " + num(rec.duration()) + " s)";
  if (has_t && rec.rate_hz > kMaxSampleRateHz)
    throw InputError(path + ": " + times + ": the times give " + span + ", beyond the " + num(kMaxSampleRateHz / 1e3) +
                     " kHz limit of a recording's rate (" + band + "): t must be in seconds");
  // Times counted from an epoch (a Unix time, 1.7e9 s; a clock in ns read as s) keep only
  // |t| 2^-52 s of resolution: past 1% of the sample interval the times, and the rate they give,
  // are rounded.
  const double newest = std::max(std::fabs(rec.t.front()), std::fabs(rec.t.back()));
  const double resolution = newest * std::numeric_limits<double>::epsilon();
  if (has_t && rec.rate_hz > 0 && resolution > 0.01 / rec.rate_hz)
    return times + ": times near " + num(newest) + " s keep only " + num(resolution) + " s of resolution, " +
           num(100 * resolution * rec.rate_hz) + "% of the " + num(1e3 / rec.rate_hz) +
           " ms between samples: the times and the rate (" + num(rec.rate_hz) + " Hz) are rounded; count t from the log's start";
  if (!(rec.rate_hz < kMinPlausibleLogRateHz)) return "";
  if (!has_t) {
    const double khz = rec.rate_hz * 1e3;
    return "--rate " + num(rec.rate_hz) + " Hz is below " + num(kMinPlausibleLogRateHz) + " Hz; " + band +
           (khz >= kDeviceRateLowHz && khz <= kDeviceRateHighHz ? " (the rate is in Hz: --rate " + num(khz) + "?)" : "");
  }
  const std::string slow = times + ": the times give " + span + ", below " + num(kMinPlausibleLogRateHz) + " Hz; " + band;
  const TimeUnit unit = likely_time_unit(rec.rate_hz);
  if (!unit.name) return slow + ": is t in seconds (else --time-unit ms, us or ns)?";
  const std::string looks = slow + ": the times look like " + unit.name + " (" + num(unit.rate_hz) +
                            " Hz): import again with --time-unit " + unit.symbol;
  if (!unit_given) throw InputError(path + ": " + looks + " (--time-unit s keeps them as seconds)");
  return looks;
}

// The longest interval between a log's times, when it is a gap in the logging (over
// kLogGapFactor times the median interval and two of the slowest device's): what a replay fills
// with a straight line. "" when there is none. `times` as check_log_rate's; `places`: what line_of
// counts ("lines", a bag's topic's messages).
std::string check_log_gaps(const Recording& rec, const std::vector<std::size_t>& line_of, const std::string& times,
                           const std::string& places) {
  const std::optional<LogGaps> g = find_log_gaps(rec.t);
  if (!g) return "";
  const std::size_t longest = g->longest;
  const double gap = rec.t[longest + 1] - rec.t[longest];
  return times + ": " + std::string(g->count == 1 ? "a gap" : std::to_string(g->count) + " gaps, the longest") + " of " +
         num(gap) + " s between " + places + " " + std::to_string(line_of[longest]) + " and " +
         std::to_string(line_of[longest + 1]) + " (t = " + num(rec.t[longest]) + " .. " + num(rec.t[longest + 1]) +
         " s), " + num(gap / g->median) + " times the median interval of " + num(g->median * 1e3) +
         " ms: the logger missed samples there, and a replay moves the tool in a straight line across " +
         (g->count == 1 ? "it" : "them");
}

}  // namespace

double parse_length_unit(const std::string& name) {
  if (const std::optional<double> m = length_unit_metres(name)) return *m;
  throw InputError("--unit: '" + name + "' is not one of " + kLengthUnitList);
}

RigidTransform parse_rigid_transform(const std::string& option, const std::string& text, double unit_m) {
  auto tok = split_commas(text);
  if (tok.size() != 6)
    throw InputError(option + ": expected 6 comma-separated numbers x,y,z,rx,ry,rz (translation, then a rotation "
                              "vector in degrees), got '" + clipped(text) + "'");
  double v[6];
  const char* names[6] = {"x", "y", "z", "rx", "ry", "rz"};  // as the message above names them
  for (int i = 0; i < 6; ++i) {
    v[i] = to_number(tok[i], option, names[i]);
    if (!std::isfinite(v[i])) throw InputError(option + ": " + names[i] + " is not finite, got '" + clipped(tok[i]) + "'");
  }
  const Vec3d rotvec{v[3], v[4], v[5]};
  if (const std::string why = rotvec_deg_problem(rotvec); !why.empty()) throw InputError(option + ": " + why);
  const Vec3d translation = Vec3d{v[0], v[1], v[2]} * unit_m;
  if (const std::string why = translation_problem(translation); !why.empty())
    throw InputError(option + " " + text + ": " + why);
  return RigidTransform{translation, quat_from_rotvec(rotvec * (std::numbers::pi / 180.0))};
}

LogFormat log_format_of(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".csv") return LogFormat::csv;
  const bool unindexed = ext == ".active" && lower_extension(path.substr(0, path.size() - 7)) == ".bag";
  if (ext == ".bag" || ext == ".mcap" || ext == ".db3" || unindexed)
    return LogFormat::rosbag;
  return LogFormat::openhaptics;
}

double nominal_rate(const std::vector<double>& t) {
  const double span = t.back() - t.front();
  // The device's period is the median interval, as the rate checks take it: a gap where the logger
  // missed samples (1 s in a 1 kHz log of 1.4 s gave 285 Hz as the mean) and a hold leave it be.
  // Two samples have one interval.
  const double period = t.size() >= 3 ? median_interval(t) : span;
  // Times counted from an epoch carry |t| 2^-52 s of round-off at each end of an interval (a
  // 10 kHz log in Unix time gave 9999.99999 Hz over its span, and single intervals of 419 or 420
  // units of 2.4e-7 s): the relative error that leaves in a rate over `over` seconds, or 1e-9.
  const double newest = std::max(std::fabs(t.front()), std::fabs(t.back()));
  const auto tolerance = [newest](double over) {
    return std::max(1e-9, 4 * std::numeric_limits<double>::epsilon() * newest / over);
  };
  double rate = 1 / period, within = tolerance(period);
  // Where the mean rate over the span is the same number to the period's round-off (a log with no
  // gap), it is taken: its round-off is the span's, not one interval's.
  if (const double mean = static_cast<double>(t.size() - 1) / span; std::fabs(mean - rate) <= within * rate) {
    rate = mean;
    within = tolerance(span);
  }
  const double whole = std::round(rate);
  return whole > 0 && std::fabs(rate - whole) <= within * whole ? whole : rate;
}

std::pair<double, double> parse_jaw_range(const std::string& text) {
  const auto comma = text.find(',');
  double v[2] = {0, 0};
  bool ok = comma != std::string::npos && text.find(',', comma + 1) == std::string::npos;
  for (int k = 0; ok && k < 2; ++k) {
    const std::string part = k == 0 ? text.substr(0, comma) : text.substr(comma + 1);
    char* end = nullptr;
    v[k] = std::strtod(part.c_str(), &end);
    ok = !part.empty() && end && *end == '\0' && std::isfinite(v[k]);
  }
  if (!ok) throw InputError("--jaw-range '" + text + "': expected CLOSED,OPEN, two numbers (the log's jaw values)");
  if (v[0] == v[1]) throw InputError("--jaw-range '" + text + "': the closed and open values are the same");
  if (!std::isfinite(v[1] - v[0]))  // the span overflows: every value would map to 0
    throw InputError("--jaw-range '" + text + "': the span from closed to open is not a finite number");
  return {v[0], v[1]};
}

double parse_time_unit(const std::string& name) {
  if (name == "s") return 1;
  if (name == "ms") return 1e-3;
  if (name == "us") return 1e-6;
  if (name == "ns") return 1e-9;
  throw InputError("--time-unit: '" + name + "' is not one of s, ms, us, ns");
}

Recording import_log(const std::string& path, const ImportOptions& opt, ImportReport* report) {
  const double rate_hz = opt.rate_hz.value_or(kAssumedLogRateHz);
  if (!(rate_hz > 0 && rate_hz <= kMaxSampleRateHz))
    throw InputError("--rate: expected a number in (0, " + std::to_string(static_cast<long>(kMaxSampleRateHz)) +
                     "] Hz");
  const LogFormat fmt = opt.format ? *opt.format : log_format_of(path);
  const double unit = opt.unit ? *opt.unit : (fmt == LogFormat::openhaptics ? 1e-3 : 1.0);
  Recording rec;
  std::vector<std::size_t> line_of;
  bool has_t = false, csv_has_jaw = false;  // the log has times; a CSV log a jaw column, a bag a jaw topic
  double time_unit = opt.time_unit.value_or(1.0);  // a ROS export's: nanoseconds
  std::string layout_note;
  LeftOut left_out;
  if (!(opt.start_s >= 0)) throw InputError("--start: expected seconds >= 0");
  if (opt.duration_s && !(*opt.duration_s > 0)) throw InputError("--duration: expected seconds > 0");
  LogWindow window{opt.start_s, opt.duration_s, std::nullopt};
  const bool bag = fmt == LogFormat::rosbag;
  if (!bag && !opt.topic.empty()) throw InputError("--topic: " + path + " is not a ROS bag (*.bag): the option names a bag's topic");
  if (!bag && !opt.frame.empty()) throw InputError("--frame: " + path + " is not a ROS bag (*.bag): the option names a tf frame");
  if (!bag && !opt.root_frame.empty())
    throw InputError("--root-frame: " + path + " is not a ROS bag (*.bag): the option names a tf frame");
  if (!bag && !opt.button_topic.empty())
    throw InputError("--button-topic: " + path + " is not a ROS bag (*.bag): the option names a bag's topic");
  if (!bag && !opt.jaw_joint.empty())
    throw InputError("--jaw-joint: " + path + " is not a ROS bag (*.bag): the option names a bag's joint");
  if (!bag && !opt.jaw_topic.empty())
    throw InputError("--jaw-topic: " + path + " is not a ROS bag (*.bag): the option names a bag's topic");
  if (bag && opt.time_unit) throw InputError("--time-unit: " + path + " is a ROS bag, whose times are ROS times (seconds)");
  if (bag && opt.rate_hz) throw InputError("--rate: " + path + " is a ROS bag, whose messages carry their times");
  std::size_t cut_bytes = 0;
  std::string bag_kind, topic;  // a bag's kind and pose topic
  try {
    if (fmt == LogFormat::openhaptics)
      read_openhaptics(path, unit, rate_hz, opt.max_samples, window, rec, line_of, left_out);
    else if (bag) {
      std::tie(bag_kind, topic) = read_bag(path, unit, opt, window, rec, line_of, csv_has_jaw, layout_note, cut_bytes);
      has_t = true;
    } else
      read_csv(path, unit, rate_hz, time_unit, opt.max_samples, window, rec, line_of, has_t, csv_has_jaw, left_out,
               opt.skip_columns, opt.time_unit.has_value(), layout_note);
  } catch (const std::bad_alloc&) {  // a memory limit (ulimit -v, a job's) below what the log needs
    const std::size_t rows = rec.t.size();
    rec = Recording{};
    throw InputError(path + ": out of memory after reading " + std::to_string(rows) +
                     " samples (~" + std::to_string(kImportBytesPerSample) +
                     " bytes each while importing): give the process more memory (ulimit -v, the job's limit), or "
                     "import the log in parts");
  }
  if (rec.t.size() < 2 && window.origin && !window.whole()) {
    char span[64];
    std::snprintf(span, sizeof span, "%.6g", window.span);
    throw InputError(path + ": " + (rec.t.empty() ? "no samples" : "one sample") + " in the window --start " +
                     shortest_text(opt.start_s) +
                     (opt.duration_s ? " --duration " + shortest_text(*opt.duration_s) : std::string()) +
                     ": the log's samples span " + span + " s from its first" +
                     (rec.t.empty() ? "" : "; a recording needs at least two: widen the window"));
  }
  if (rec.t.empty())
    throw InputError(path + ": no samples (the log has no data lines" +
                     (left_out.cut_line ? "; its only one, line " + std::to_string(left_out.cut_line) +
                                              ", has no line end"
                                        : std::string()) +
                     ")");

  if (opt.time_unit && !has_t)
    throw InputError("--time-unit: " + path + " has no t column (its samples are --rate apart): the unit is for a "
                     "CSV log's times");
  // The log's times in seconds (a clock in ms or ns), before anything reads them as such.
  if (time_unit != 1)
    for (double& t : rec.t) t *= time_unit;
  rec.source = "device";
  rec.scene = opt.scene;
  rec.tool = opt.tool;
  rec.description = std::string("imported from ") + path + " (" +
                    (fmt == LogFormat::csv ? "csv" : bag ? bag_kind + ", topic " + topic : "openhaptics") + ")";
  // What was baked into the poses, for a reader (rec.baked is the record replay checks).
  if (opt.mirror)
    rec.description += std::string("; a left-handed log, its ") + static_cast<char>('x' + *opt.mirror) + " axis reversed";
  if (opt.transforms.tool) rec.description += "; tool transform " + describe(*opt.transforms.tool) + " applied";
  if (opt.transforms.world) rec.description += "; world transform " + describe(*opt.transforms.world) + " applied";
  // The rate as given; with times, the rate they give replaces it once the validator has them
  // increasing (below).
  rec.rate_hz = rate_hz;
  // --jaw-range maps the log's jaw values; a CSV log without a jaw column has none (its samples
  // are open), which the range would have mapped to a value of its own (0,255: closed).
  if (opt.jaw_button && opt.jaw_range) throw InputError("--jaw-button and --jaw-range: the jaw comes from one of them");
  if (opt.jaw_range && bag && !csv_has_jaw)
    throw InputError("--jaw-range: " + path + " is read without a jaw topic (its samples are taken open, 1): name the "
                     "gripper's topic with --jaw-topic");
  if (opt.jaw_range && fmt == LogFormat::csv && !csv_has_jaw)
    throw InputError("--jaw-range: " + path + " has no jaw column (its samples are taken open, 1): the range maps a "
                     "logged jaw; leave it out, or add the jaw column");
  // Where sample i came from: a text log's line, a bag's message.
  const auto where = [&](std::size_t i) {
    return bag ? path + ": " + topic + " message " + std::to_string(line_of[i]) : at(path, line_of[i]);
  };
  // The jaw in the log's own range, mapped to 0 closed .. 1 open; without a range one outside
  // [0, 1] is refused here, naming the option that maps it. Repeats are the log's own: two
  // readings that the clamp makes equal are two readings.
  const std::vector<double> logged_jaw = opt.jaw_range ? rec.jaw : std::vector<double>{};
  std::size_t jaw_clamped = 0, first_jaw_clamped = 0;
  for (std::size_t i = 0; i < rec.size(); ++i) {
    double& j = rec.jaw[i];
    if (!std::isfinite(j)) continue;  // the validator's to name
    if (opt.jaw_range) {
      j = (j - opt.jaw_range->first) / (opt.jaw_range->second - opt.jaw_range->first);
      if (j < -kJawTolerance || j > 1 + kJawTolerance)
        if (jaw_clamped++ == 0) first_jaw_clamped = line_of[i];
      j = std::clamp(j, 0.0, 1.0);
    } else if (j < -kJawTolerance || j > 1 + kJawTolerance) {
      throw InputError(where(i) + ": jaw " + num(j) +
                       " outside [0, 1] (0 closed, 1 open): give the log's values when closed and open, --jaw-range "
                       "CLOSED,OPEN (--jaw-range 0,1 clamps a gripper calibrated a little past its ends)");
    }
  }
  // --jaw-button: the jaw from a button, where the device has no gripper; a logged jaw that moves
  // is a gripper's, which the button would silently replace.
  std::size_t presses = 0;
  if (opt.jaw_button) {
    const int b = *opt.jaw_button;
    for (std::size_t i = 1; i < rec.size(); ++i)
      if (rec.jaw[i] != rec.jaw[0])
        throw InputError(where(i) + ": --jaw-button " + std::to_string(b) + ": the log's jaw moves (" +
                         shortest_text(rec.jaw[0]) + " at its first sample, " + shortest_text(rec.jaw[i]) +
                         " here): a gripper's, which the button would replace; leave --jaw-button out");
    for (std::size_t i = 0; i < rec.size(); ++i) rec.jaw[i] = (rec.buttons[i] >> b) & 1 ? 0.0 : 1.0;
    presses = button_presses(rec.buttons, b);
  }
  // Validated before repeats are dropped, so an error names the log's own line.
  validate_recording(rec, path, [&](std::string_view, std::size_t i) { return where(i); });
  // The rate the log's own times say (of every sample, repeats included): its median interval's.
  if (has_t) rec.rate_hz = nominal_rate(rec.t);
  const std::string times = bag ? "the messages' times" : "column t";
  const std::string rate_warning = check_log_rate(rec, has_t, bag || opt.time_unit || time_unit != 1, path, times);
  // On unit quaternions (the validator normalised them); turning every sample by the same
  // rotations keeps consecutive ones in the same hemisphere, and equal samples equal.
  if (opt.mirror) {
    mirror_poses(*opt.mirror, rec.position, rec.orientation);
    rec.baked_mirror = std::string(1, static_cast<char>('x' + *opt.mirror));
  }
  apply_pose_transforms(opt.transforms, rec.position, rec.orientation);
  rec.baked = opt.transforms;

  ImportReport r;
  r.layout_note = layout_note;
  r.has_times = has_t;
  r.rate_assumed = !has_t && !opt.rate_hz;
  r.rate_warning = rate_warning;
  r.cut_line = left_out.cut_line;
  r.cut_bytes = cut_bytes;
  if (bag) r.place = topic + " message";
  r.duplicate_rows = left_out.duplicate_rows;
  r.first_duplicate_line = left_out.first_duplicate;
  if (has_t) r.gap_warning = check_log_gaps(rec, line_of, times, bag ? topic + " messages" : "lines");
  r.jaw_clamped = jaw_clamped;
  r.first_jaw_clamped_line = first_jaw_clamped;
  r.jaw_button_presses = presses;
  // Runs of repeats: sample i is new, samples i+1..j repeat it. A short run is stale samples of a
  // device polled faster than it updates; a run lasting more than kStaleRunMaxS is a hold (the
  // device at rest) and keeps its last sample, so a replay holds still until the device moves
  // instead of creeping toward the next new sample; the log's last sample is kept, so the
  // recording keeps its length.
  std::vector<std::size_t> keep;
  const std::vector<double>& jaw = opt.jaw_range ? logged_jaw : rec.jaw;  // without a range, the same values
  const auto repeats = [&rec, &jaw](std::size_t i) { return repeats_previous(rec, i, jaw); };
  for (std::size_t i = 0; i < rec.size();) {
    std::size_t j = i;
    while (j + 1 < rec.size() && repeats(j + 1)) ++j;
    keep.push_back(i);
    const std::size_t run = j - i;
    r.repeats += run;
    // A quarter of the log's interval absorbs its times' jitter and round-off: at 1 kHz a run of
    // 10 repeats (10 ms) is stale, one of 11 a hold.
    const bool hold = run > 0 && rec.t[j] - rec.t[i] > kStaleRunMaxS + 0.25 / rec.rate_hz;
    if (hold) ++r.holds;
    if (run > 0 && (hold || j + 1 == rec.size())) keep.push_back(j);
    i = j + 1;
  }
  r.removable = rec.size() - keep.size();
  r.dropped = opt.drop_repeats && r.repeats > 0;
  if (!r.dropped) r.stale_warning = check_recording_stale(rec).value_or("");
  if (r.dropped) {
    auto select = [&keep](auto& v) {
      std::remove_reference_t<decltype(v)> out;
      out.reserve(keep.size());
      for (std::size_t i : keep) out.push_back(v[i]);
      v = std::move(out);
    };
    select(rec.t);
    select(rec.position);
    select(rec.orientation);
    select(rec.jaw);
    select(rec.buttons);
  }
  if (report) *report = r;
  return rec;
}

}  // namespace ebh
