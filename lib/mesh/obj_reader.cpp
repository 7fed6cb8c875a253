// Wavefront OBJ surface reader: `v` and `f` lines only.
#include <algorithm>
#include <charconv>
#include <climits>
#include <string>
#include <vector>

#include "mesh/mesh_io.hpp"
#include "mesh/polygon.hpp"
#include "mesh/text_cursor.hpp"

namespace ebh {
namespace {

using detail::printable;

/// Parses the vertex part of a face corner ("7", "7/2", "7/2/5", "7//5", "-1/...") and checks
/// that the rest has the corner's form. Returns false if the token is malformed.
bool parse_corner(std::string_view t, long long* v) {
  auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), *v);
  // An index too large for any count: read as the extreme of its sign, which the caller refuses
  // as out of range (naming the file's text), not as a corner of another form.
  if (ec == std::errc::result_out_of_range) *v = t.front() == '-' ? LLONG_MIN : LLONG_MAX;
  else if (ec != std::errc()) return false;
  const char* end = t.data() + t.size();
  int slashes = 0;
  for (; p < end; ++p) {
    if (*p == '/') {
      if (++slashes > 2) return false;
    } else if (!((*p >= '0' && *p <= '9') || (*p == '-' && p[-1] == '/'))) {
      return false;
    }
  }
  return true;
}

/// Refuses what is not text: a gzip-compressed file (its magic bytes first) or one with a NUL byte.
void check_text(const std::filesystem::path& file, std::string_view text) {
  if (text.starts_with("\x1f\x8b"))
    throw InputError(file.string() + ":1: a gzip-compressed file, not a text OBJ: decompress it first (gunzip)");
  if (const auto nul = text.find('\0'); nul != std::string_view::npos)
    throw InputError(file.string() + ":" + std::to_string(1 + std::count(text.begin(), text.begin() + nul, '\n')) +
                     ": a NUL byte: a binary file, not a text OBJ");
}

/// OBJ's line continuation: a line that ends in '\' goes on on the next one. Each such '\' and
/// its line break become a blank, and the line breaks come back after the joined line, so every
/// other line keeps its number (an error on a joined line names its first).
void join_continued_lines(std::string& text) {
  if (text.find('\\') == std::string::npos) return;
  std::string out;
  out.reserve(text.size());
  std::size_t joined = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\\') {
      std::size_t j = i + 1;
      if (j < text.size() && text[j] == '\r') ++j;
      if (j < text.size() && text[j] == '\n') {
        out += ' ';
        ++joined;
        i = j;
        continue;
      }
    }
    out += text[i];
    if (text[i] == '\n') {
      out.append(joined, '\n');
      joined = 0;
    }
  }
  text = std::move(out);
}

/// A polygon of more than 3 corners, fan-triangulated: right only when it is convex.
struct Polygon {
  long long line;
  std::vector<long long> corners;
};

}  // namespace

SurfaceMesh read_obj(const std::filesystem::path& file) {
  std::string text = detail::read_file_bytes(file);
  check_text(file, text);
  join_continued_lines(text);
  detail::TextCursor c(file, text);
  std::vector<Polygon> polygons;
  SurfaceMesh mesh;
  std::vector<long long> tri_lines;  // line of each triangle, for range errors at the end
  std::vector<long long> corners;
  while (c.skip_empty_lines()) {
    const std::string_view kind = c.token();
    if (kind == "v") {
      const double x = c.real("x coordinate");
      const double y = c.real("y coordinate");
      const double z = c.real("z coordinate");
      if (mesh.vertices.size() >= static_cast<std::size_t>(INT_MAX)) c.fail("too many vertices");
      mesh.vertices.push_back({x, y, z});  // an optional w or colour may follow: ignored
    } else if (kind == "f") {
      corners.clear();
      for (std::string_view t = c.token(); !t.empty(); t = c.token()) {
        if (t.front() == '#') break;  // a comment to the end of the line
        long long v = 0;
        if (!parse_corner(t, &v)) c.fail("expected a face corner like 3, 3/1, 3/1/2 or 3//2, got '" + printable(t) + "'");
        if (v == 0) c.fail("vertex index 0 is invalid (OBJ indices start at 1)");
        const std::string index = printable(t.substr(0, t.find('/')));  // as the file writes it
        if (v < 0) {
          const long long abs_index = v == LLONG_MIN ? -1 : static_cast<long long>(mesh.vertices.size()) + v;
          if (abs_index < 0)
            c.fail("relative vertex index " + index + " reaches before the first vertex (" +
                   std::to_string(mesh.vertices.size()) + " read so far)");
          v = abs_index;
        } else {
          if (v > INT_MAX) c.fail("vertex index " + index + " is out of range");
          v -= 1;  // checked against the vertex count at the end: OBJ allows forward references
        }
        corners.push_back(v);
      }
      if (corners.size() < 3) c.fail("a face needs at least 3 vertices, got " + std::to_string(corners.size()));
      for (std::size_t a = 0; a < corners.size(); ++a)
        for (std::size_t b = a + 1; b < corners.size(); ++b)
          if (corners[a] == corners[b])
            c.fail("the face names vertex " + std::to_string(corners[a] + 1) + " twice (a degenerate face)");
      if (corners.size() > 3) polygons.push_back({c.line(), corners});
      detail::append_fan(corners, mesh.triangles);
      tri_lines.resize(mesh.triangles.size(), c.line());
    }
    c.next_line();
  }
  const auto nv = static_cast<long long>(mesh.vertices.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (mesh.triangles[t][k] >= nv)
        c.fail_at(tri_lines[t], "vertex index " + std::to_string(mesh.triangles[t][k] + 1) + " is out of range (the file has " +
                                    std::to_string(nv) + " vertices)");
  for (const Polygon& p : polygons)
    if (const int k = detail::concave_corner(p.corners, mesh.vertices); k >= 0)
      c.fail_at(p.line, detail::concave_message(p.corners.size(), p.corners[static_cast<std::size_t>(k)] + 1));
  if (mesh.triangles.empty()) c.fail("no faces ('f' lines) in the file");
  return mesh;
}

}  // namespace ebh
