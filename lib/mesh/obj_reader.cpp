// Wavefront OBJ surface reader: `v` and `f` lines only.
#include <charconv>
#include <climits>

#include "mesh/mesh_io.hpp"
#include "mesh/text_cursor.hpp"

namespace ebh {
namespace {

using detail::printable;

/// Parses the vertex part of a face corner ("7", "7/2", "7/2/5", "7//5", "-1/...") and checks
/// that the rest has the corner's form. Returns false if the token is malformed.
bool parse_corner(std::string_view t, long long* v) {
  auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), *v);
  if (ec != std::errc()) return false;
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

}  // namespace

SurfaceMesh read_obj(const std::filesystem::path& file) {
  const std::string text = detail::read_file_bytes(file);
  detail::TextCursor c(file, text);
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
        long long v = 0;
        if (!parse_corner(t, &v)) c.fail("expected a face corner like 3, 3/1, 3/1/2 or 3//2, got '" + printable(t) + "'");
        if (v == 0) c.fail("vertex index 0 is invalid (OBJ indices start at 1)");
        if (v < 0) {
          const long long abs_index = static_cast<long long>(mesh.vertices.size()) + v;
          if (abs_index < 0)
            c.fail("relative vertex index " + std::to_string(v) + " reaches before the first vertex (" +
                   std::to_string(mesh.vertices.size()) + " read so far)");
          v = abs_index;
        } else {
          if (v > INT_MAX) c.fail("vertex index " + std::to_string(v) + " is out of range");
          v -= 1;  // checked against the vertex count at the end: OBJ allows forward references
        }
        corners.push_back(v);
      }
      if (corners.size() < 3) c.fail("a face needs at least 3 vertices, got " + std::to_string(corners.size()));
      for (std::size_t a = 0; a < corners.size(); ++a)
        for (std::size_t b = a + 1; b < corners.size(); ++b)
          if (corners[a] == corners[b])
            c.fail("the face names vertex " + std::to_string(corners[a] + 1) + " twice (a degenerate face)");
      for (std::size_t k = 1; k + 1 < corners.size(); ++k) {
        mesh.triangles.push_back({static_cast<int>(corners[0]), static_cast<int>(corners[k]), static_cast<int>(corners[k + 1])});
        tri_lines.push_back(c.line());
      }
    }
    c.next_line();
  }
  const auto nv = static_cast<long long>(mesh.vertices.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (mesh.triangles[t][k] >= nv)
        c.fail_at(tri_lines[t], "vertex index " + std::to_string(mesh.triangles[t][k] + 1) + " is out of range (the file has " +
                                    std::to_string(nv) + " vertices)");
  if (mesh.triangles.empty()) c.fail("no faces ('f' lines) in the file");
  return mesh;
}

}  // namespace ebh
