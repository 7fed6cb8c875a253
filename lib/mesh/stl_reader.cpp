// STL surface reader (ASCII and binary): a virtual-mesh surface as segmentation tools export it.
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "core/file_names.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/text_cursor.hpp"

namespace ebh {
namespace {

using detail::printable;
using detail::TextCursor;

constexpr std::size_t kBinaryHeader = 84;  // 80 bytes of header, the facet count (uint32)
constexpr std::size_t kBinaryFacet = 50;   // normal and 3 corners (12 float32), attribute (uint16)

/// Facets in, a surface out: corners at exactly the same position are one vertex (an STL repeats
/// each corner in every facet that has it), numbered in the order they first appear.
class Welder {
 public:
  void corner(const Vec3d& p) {
    // 0 and -0 alike
    const std::array<double, 3> key{p.x == 0 ? 0.0 : p.x, p.y == 0 ? 0.0 : p.y, p.z == 0 ? 0.0 : p.z};
    const auto [it, fresh] = index_.emplace(key, static_cast<int>(out_.vertices.size()));
    if (fresh) out_.vertices.push_back(Vec3d{key[0], key[1], key[2]});
    facet_[corners_++] = it->second;
    if (corners_ == 3) {
      out_.triangles.push_back(facet_);
      corners_ = 0;
    }
  }
  SurfaceMesh take() { return std::move(out_); }

 private:
  std::map<std::array<double, 3>, int> index_;
  SurfaceMesh out_;
  Tri facet_{};
  int corners_ = 0;
};

/// A facet's corner from a binary STL: three little-endian float32.
Vec3d corner_at(const char* p) {
  float v[3];
  static_assert(sizeof v == 12);
  std::memcpy(v, p, sizeof v);  // the file's byte order is the machine's on every target ebh builds for
  return Vec3d{v[0], v[1], v[2]};
}

SurfaceMesh read_binary(const std::filesystem::path& file, std::string_view bytes, std::uint32_t facets) {
  Welder w;
  for (std::uint32_t f = 0; f < facets; ++f) {
    const char* p = bytes.data() + kBinaryHeader + kBinaryFacet * f;
    for (int k = 0; k < 3; ++k) {
      const Vec3d c = corner_at(p + 12 + 12 * k);
      if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z))
        throw InputError(file.string() + ": facet " + std::to_string(f) + " (a binary STL's) has a corner that is "
                         "not a finite number");
      w.corner(c);
    }
  }
  return w.take();
}

/// Requires the keyword `word` as the next token.
void expect(TextCursor& c, std::string_view word, const char* after) {
  const std::string_view t = c.token();
  if (t == word) return;
  std::string what = "expected '";
  what.append(word).append("' ").append(after).append(", got ");
  if (t.empty())
    what += "the end of the line";
  else
    what.append(1, '\'').append(printable(t)).append(1, '\'');
  c.fail(what);
}

SurfaceMesh read_ascii(const std::filesystem::path& file, std::string_view text) {
  TextCursor c(file, text);
  Welder w;
  bool solid = false;  // inside solid ... endsolid
  long long solid_line = 0;
  while (c.skip_empty_lines()) {
    const std::string_view t = c.token();
    if (!solid) {
      if (t != "solid") c.fail("expected 'solid', got '" + printable(t) + "'");
      solid = true;
      solid_line = c.line();
      c.next_line();  // the solid's name, if any
      continue;
    }
    if (t == "endsolid") {
      solid = false;
      c.next_line();
      continue;
    }
    if (t != "facet") c.fail("expected 'facet' or 'endsolid', got '" + printable(t) + "'");
    expect(c, "normal", "after 'facet'");
    for (int k = 0; k < 3; ++k) (void)c.real("normal component");  // not used: the corners' order is the facet's
    c.end_line("");
    c.skip_empty_lines();
    expect(c, "outer", "in a facet");
    expect(c, "loop", "after 'outer'");
    c.end_line("");
    for (int k = 0; k < 3; ++k) {
      c.skip_empty_lines();
      expect(c, "vertex", "(a facet has 3)");
      const double x = c.real("x coordinate"), y = c.real("y coordinate"), z = c.real("z coordinate");
      c.end_line("");
      w.corner(Vec3d{x, y, z});
    }
    c.skip_empty_lines();
    expect(c, "endloop", "after a facet's 3 vertices");
    c.end_line("");
    c.skip_empty_lines();
    expect(c, "endfacet", "after 'endloop'");
    c.end_line("");
  }
  if (solid) c.fail_at(solid_line, "the file ends inside the solid begun here (no 'endsolid'): cut short?");
  return w.take();
}

}  // namespace

SurfaceMesh read_stl(const std::filesystem::path& file) {
  const std::string bytes = detail::read_file_bytes(file);
  // Binary when the size is what the facet count says: some binary writers start the header with
  // "solid" too, so the word alone does not make a file ASCII.
  std::uint32_t facets = 0;
  if (bytes.size() >= kBinaryHeader) std::memcpy(&facets, bytes.data() + 80, sizeof facets);
  const std::size_t binary_size = kBinaryHeader + kBinaryFacet * static_cast<std::size_t>(facets);
  if (bytes.size() >= kBinaryHeader && bytes.size() == binary_size) {
    if (facets == 0) throw InputError(file.string() + ": a binary STL of no facets");
    return read_binary(file, bytes, facets);
  }
  const std::string_view text(bytes);
  const std::size_t start = text.find_first_not_of(" \t\r\n");
  if (start == std::string_view::npos || text.substr(start, 5) != "solid") {
    if (bytes.size() >= kBinaryHeader)
      throw InputError(file.string() + ": neither an ASCII STL (it does not start with 'solid') nor a binary one (" +
                       std::to_string(bytes.size()) + " bytes, where its count of " + std::to_string(facets) +
                       " facets needs " + std::to_string(binary_size) + "): cut short, or another format");
    throw InputError(file.string() + ": not an STL (" + std::to_string(bytes.size()) +
                     " bytes: neither 'solid' text nor a binary header)");
  }
  if (bytes.find('\0') != std::string::npos)
    throw InputError(file.string() + ": starts with 'solid' but holds NUL bytes: a binary STL whose size (" +
                     std::to_string(bytes.size()) + " bytes) does not match its facet count: cut short?");
  SurfaceMesh s = read_ascii(file, text);
  if (s.triangles.empty()) throw InputError(file.string() + ": no facets");
  return s;
}

SurfaceMesh read_surface(const std::filesystem::path& file) {
  const std::string ext = lower_extension(file);
  SurfaceMesh s = ext == ".stl"   ? read_stl(file)
                  : ext == ".ply" ? read_ply(file)
                  : ext == ".vtk" ? read_vtk_surface(file)
                  : ext == ".vtp" ? read_vtp(file)
                                  : read_obj(file);
  // Each reader checks its indices where it reads them; this holds the result to it whatever a
  // reader missed (a count changed after its check), since the scene indexes vertices with them.
  const std::size_t n = s.vertices.size();
  for (std::size_t i = 0; i < s.triangles.size(); ++i)
    for (const int v : s.triangles[i])
      if (v < 0 || static_cast<std::size_t>(v) >= n)
        throw InputError(file.string() + ": triangle " + std::to_string(i) + ": vertex index " + std::to_string(v) +
                         " is out of range [0, " + std::to_string(n) + ")");
  return s;
}

}  // namespace ebh
