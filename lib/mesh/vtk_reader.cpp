// VTK legacy reader for the physical mesh: an UNSTRUCTURED_GRID in ASCII or BINARY (big-endian),
// file versions 2.0 to 5.1 (5.1 writes its cells as OFFSETS and CONNECTIVITY arrays).
// Format reference: "VTK File Formats", the VTK User's Guide, "Simple Legacy Formats".
#include <bit>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include "core/error.hpp"
#include "core/file_names.hpp"
#include "mesh/binary_values.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/polygon.hpp"
#include "mesh/text_cursor.hpp"
#include "mesh/vtk_names.hpp"

namespace ebh {
namespace {

using detail::printable;
using detail::TextCursor;

std::string upper(std::string_view s) {
  std::string u(s);
  for (char& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return u;
}

/// A data type of the format, its size in a binary file.
struct DataType {
  std::string name;
  int bytes = 0;
  bool real = false;  ///< float or double
  bool is_signed = true;
};

DataType data_type(TextCursor& c, std::string_view t) {
  const std::string n = upper(t);
  if (n == "FLOAT") return {n, 4, true};
  if (n == "DOUBLE") return {n, 8, true};
  if (n == "CHAR") return {n, 1};
  if (n == "UNSIGNED_CHAR") return {n, 1, false, false};
  if (n == "SHORT") return {n, 2};
  if (n == "UNSIGNED_SHORT") return {n, 2, false, false};
  if (n == "INT") return {n, 4};
  if (n == "UNSIGNED_INT") return {n, 4, false, false};
  if (n == "LONG" || n == "VTKTYPEINT64") return {n, 8};
  if (n == "UNSIGNED_LONG" || n == "VTKTYPEUINT64") return {n, 8, false, false};
  if (n == "BIT") c.fail("data type 'bit' is not read: write the mesh with int or float arrays");
  c.fail("unknown data type '" + printable(t) + "' (float, double, int, long, vtktypeint64, ...)");
}

class VtkParser {
 public:
  VtkParser(const std::filesystem::path& file, std::string bytes) : bytes_(std::move(bytes)), c_(file, bytes_) {}

  TetMesh parse() {
    header();
    std::vector<long long> cells, offsets;  // legacy: n, ids...; 5.1: the offsets and the connectivity
    std::vector<long long> types;
    bool have_cells = false, have_types = false, offsets_form = false;
    long long cells_line = 0, legacy_cells = 0;  // legacy CELLS: the number of cells
    while (next_keyword()) {
      const long long line = c_.line();
      const std::string key = upper(c_.token());
      if (key == "POINTS") {
        points(line);
      } else if (key == "CELLS") {
        const long long n = c_.integer("the number of cells", 0, INT32_MAX - 1);
        const long long size = c_.integer("the size of the cell list", 0, LLONG_MAX / 8);
        c_.end_line(" after CELLS n size");
        cells_line = line;
        if (version_ >= 5) {  // CELLS offsets connectivity, then OFFSETS type, CONNECTIVITY type
          offsets_form = true;
          offsets = array_after("OFFSETS", n, "CELLS");
          cells = array_after("CONNECTIVITY", size, "CELLS");
        } else {
          cells = integers(size, DataType{"INT", 4}, "CELLS", line);
          legacy_cells = n;
        }
        have_cells = true;
      } else if (key == "CELL_TYPES") {
        const long long n = c_.integer("the number of cell types", 0, INT32_MAX - 1);
        c_.end_line(" after CELL_TYPES n");
        types = integers(n, DataType{"INT", 4}, "CELL_TYPES", line);
        have_types = true;
      } else if (key == "FIELD") {  // a field of arrays (ParaView's TIME and CYCLE before the points)
        skip_field();
      } else if (key == "METADATA") {  // information about the array before: up to a blank line
        skip_metadata();
      } else if (key == "CELL_DATA" || key == "POINT_DATA") {
        attributes(key);  // the rest of the file
        break;
      } else {
        fail(line, "unexpected '" + printable(key) + "' (expected POINTS, CELLS, CELL_TYPES, CELL_DATA or POINT_DATA)");
      }
    }
    if (points_line_ == 0) fail(c_.line(), "no POINTS section");
    if (!have_cells || !have_types) fail(c_.line(), std::string("no ") + (have_cells ? "CELL_TYPES" : "CELLS") + " section");
    build(cells, offsets, offsets_form, legacy_cells, types, cells_line);
    if (!groups_name_.empty()) take_groups(types);
    return std::move(mesh_);
  }

 private:
  [[noreturn]] void fail(long long line, const std::string& what) const { c_.fail_at(line, what); }

  void header(bool surface = false) {
    const std::string_view first = c_.rest_of_line();
    if (!first.starts_with("# vtk DataFile Version"))
      fail(1, "not a VTK legacy file (its first line is not '# vtk DataFile Version x.y'): a physical mesh is a Gmsh "
              ".msh or a VTK .vtk file");
    const std::string_view v = first.substr(std::string_view("# vtk DataFile Version").size());
    version_ = 0;
    for (const char ch : v)
      if (std::isdigit(static_cast<unsigned char>(ch))) {
        version_ = ch - '0';
        break;
      }
    c_.next_line();  // the title, any text
    c_.next_line();
    const std::string mode = upper(c_.rest_of_line());
    if (mode != "ASCII" && mode != "BINARY") fail(3, "expected ASCII or BINARY, got '" + printable(mode) + "'");
    binary_ = mode == "BINARY";
    c_.next_line();
    if (!c_.skip_empty_lines()) fail(c_.line(), "no DATASET line");
    const long long line = c_.line();
    const std::string wanted = surface ? "POLYDATA" : "UNSTRUCTURED_GRID";
    if (upper(c_.token()) != "DATASET") fail(line, "expected DATASET " + wanted);
    const std::string kind = upper(c_.token());
    if (kind != wanted && surface)
      fail(line, "a DATASET " + printable(kind) + " is no surface: the virtual mesh is a POLYDATA of polygons" +
                     (kind == "UNSTRUCTURED_GRID" ? std::string(" (this file can be the physical mesh)") : std::string()));
    if (kind != wanted)
      fail(line, "a DATASET " + printable(kind) + " holds no tetrahedra (" +
                     (kind == "POLYDATA" ? std::string("a surface: it can be the virtual mesh") : std::string("a grid")) +
                     "): the physical mesh is an UNSTRUCTURED_GRID of tets");
    c_.end_line(" after DATASET " + wanted);
  }

 public:
  /// A POLYDATA's surface: its POINTS and its POLYGONS and TRIANGLE_STRIPS as triangles (polygons
  /// split around their first corner, convex ones only; strips in alternating order); VERTICES
  /// and LINES read past; the attributes after them not read.
  SurfaceMesh parse_surface() {
    header(true);
    SurfaceMesh out;
    while (next_keyword()) {
      const long long line = c_.line();
      const std::string key = upper(c_.token());
      if (key == "POINTS") {
        points(line);
      } else if (key == "POLYGONS" || key == "TRIANGLE_STRIPS" || key == "VERTICES" || key == "LINES") {
        const std::vector<std::vector<long long>> cells = cell_list(key, line);
        const long long nv = static_cast<long long>(mesh_.vertices.size());
        if (key == "VERTICES" || key == "LINES") continue;
        for (std::size_t i = 0; i < cells.size(); ++i) {
          const std::vector<long long>& c = cells[i];
          const std::string which = key + " cell " + std::to_string(i) + ": ";
          if (c.size() < 3) fail(line, which + std::to_string(c.size()) + " points, a " + (key == "POLYGONS" ? "polygon" : "strip") + " needs 3 at least");
          for (long long id : c)
            if (id < 0 || id >= nv) fail(line, which + "point index " + std::to_string(id) + " is out of range [0, " + std::to_string(nv) + ")");
          if (key == "TRIANGLE_STRIPS") {
            detail::append_strip(c, out.triangles);
            continue;
          }
          if (c.size() > 3)
            if (const int k = detail::concave_corner(c, mesh_.vertices); k >= 0)
              fail(line, which + detail::concave_message(c.size(), c[static_cast<std::size_t>(k)]));
          detail::append_fan(c, out.triangles);
        }
      } else if (key == "FIELD") {
        skip_field();
      } else if (key == "METADATA") {
        skip_metadata();
      } else if (key == "CELL_DATA" || key == "POINT_DATA") {
        break;  // colours, normals: not the surface's
      } else {
        fail(line, "unexpected '" + printable(key) + "' (expected POINTS, POLYGONS, TRIANGLE_STRIPS, ...)");
      }
    }
    if (mesh_.vertices.empty() && out.triangles.empty()) fail(c_.line(), "no POINTS section");
    if (out.triangles.empty()) fail(c_.line(), "no POLYGONS or TRIANGLE_STRIPS: a surface is a list of polygons");
    out.vertices = std::move(mesh_.vertices);
    return out;
  }

 private:
  /// POINTS n type and its values into mesh_.vertices. Once only: the cells' point indices are
  /// checked against its count.
  void points(long long line) {
    if (points_line_ > 0) fail(line, "a second POINTS section (the first at line " + std::to_string(points_line_) + ")");
    points_line_ = line;
    const long long n = c_.integer("the number of points", 0, INT32_MAX - 1);
    const DataType t = data_type(c_, c_.token());
    c_.end_line(" after POINTS n type");
    const std::vector<double> xyz = reals(3 * n, t, "POINTS", line);
    mesh_.vertices.resize(static_cast<std::size_t>(n));
    for (long long i = 0; i < n; ++i) {
      const Vec3d p{xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        fail(line, "point " + std::to_string(i) + " has a non-finite coordinate");
      mesh_.vertices[static_cast<std::size_t>(i)] = p;
    }
  }

  /// A POLYDATA cell section (KEY n size, then the legacy list or 5.1's OFFSETS and CONNECTIVITY):
  /// each cell's point indices.
  std::vector<std::vector<long long>> cell_list(const std::string& key, long long line) {
    const long long n = c_.integer("the number of cells", 0, INT32_MAX - 1);
    const long long size = c_.integer("the size of the cell list", 0, LLONG_MAX / 8);
    c_.end_line(" after " + key + " n size");
    std::vector<std::vector<long long>> out;
    if (version_ >= 5) {
      const std::vector<long long> offsets = array_after("OFFSETS", n, key.c_str());
      const std::vector<long long> conn = array_after("CONNECTIVITY", size, key.c_str());
      for (std::size_t i = 0; i + 1 < offsets.size(); ++i) {
        if (offsets[i] < 0 || offsets[i + 1] < offsets[i] || offsets[i + 1] > static_cast<long long>(conn.size()))
          fail(line, key + " cell " + std::to_string(i) + ": OFFSETS " + std::to_string(offsets[i]) + ".." +
                         std::to_string(offsets[i + 1]) + " is not a range of the " + std::to_string(conn.size()) + " CONNECTIVITY entries");
        out.emplace_back(conn.begin() + offsets[i], conn.begin() + offsets[i + 1]);
      }
      return out;
    }
    const std::vector<long long> list = integers(size, DataType{"INT", 4}, key.c_str(), line);
    std::size_t at = 0;
    for (long long i = 0; i < n; ++i) {
      if (at >= list.size()) fail(line, key + ": the list ends at cell " + std::to_string(i) + " of " + std::to_string(n));
      const long long count = list[at];
      if (count < 0 || static_cast<long long>(at) + 1 + count > static_cast<long long>(list.size()))
        fail(line, key + " cell " + std::to_string(i) + ": " + std::to_string(count) + " points run past the list's size");
      out.emplace_back(list.begin() + static_cast<std::ptrdiff_t>(at + 1), list.begin() + static_cast<std::ptrdiff_t>(at + 1 + count));
      at += static_cast<std::size_t>(1 + count);
    }
    if (at != list.size())
      fail(line, key + ": its size says " + std::to_string(list.size()) + " entries, its cells use " + std::to_string(at));
    return out;
  }

  /// Moves to the next keyword line (skipping blank lines and the line ends after binary data);
  /// false at the end of the file.
  bool next_keyword() { return c_.skip_empty_lines(); }

  /// `count` values of type t (ASCII: white-space separated over any lines; binary: big-endian,
  /// starting at the current position), checked against what the file can still hold.
  template <class T, class Read>
  std::vector<T> values(long long count, const DataType& t, const char* section, long long line, Read&& ascii) {
    // ASCII values take 2 bytes at least ("0 "), binary ones their size.
    const std::size_t least = binary_ ? static_cast<std::size_t>(t.bytes) : 2;
    if (count < 0 || static_cast<std::size_t>(count) > c_.remaining() / least + 1)
      fail(line, std::string(section) + ": " + std::to_string(count) + " values do not fit in the rest of the file (" +
                     std::to_string(c_.remaining()) + " bytes): cut short?");
    std::vector<T> out(static_cast<std::size_t>(count));
    if (!binary_) {
      for (long long i = 0; i < count; ++i) {
        if (!c_.skip_empty_lines()) fail(c_.line(), std::string(section) + ": the file ends after " + std::to_string(i) + " of " + std::to_string(count) + " values");
        out[static_cast<std::size_t>(i)] = ascii();
      }
      return out;
    }
    const std::size_t at = c_.position();
    const std::size_t n = static_cast<std::size_t>(count) * static_cast<std::size_t>(t.bytes);
    if (bytes_.size() - at < n)
      fail(line, std::string(section) + ": " + std::to_string(count) + " binary values need " + std::to_string(n) +
                     " bytes, the file holds " + std::to_string(bytes_.size() - at) + " more: cut short?");
    for (std::size_t i = 0; i < out.size(); ++i) {  // big-endian, as the format writes them
      const std::uint64_t u = detail::load_bits(bytes_.data() + at + i * static_cast<std::size_t>(t.bytes), t.bytes, true);
      const long long integer = t.real ? 0 : detail::bits_as_integer(u, t.bytes, t.is_signed);
      if constexpr (std::is_same_v<T, double>) out[i] = t.real ? detail::bits_as_real(u, t.bytes) : static_cast<double>(integer);
      else out[i] = integer;
    }
    c_.pass_to(at + n);  // its bytes that are line feeds count: the lines after it are an editor's
    return out;
  }

  /// `count` values after the keyword line `line` (of `section`, for messages).
  std::vector<double> reals(long long count, const DataType& t, const char* section, long long line) {
    return values<double>(count, t, section, line, [&] { return c_.real("a coordinate"); });
  }
  std::vector<long long> integers(long long count, const DataType& t, const char* section, long long line) {
    if (t.real) fail(line, std::string(section) + ": expected an integer type, got " + t.name);
    return values<long long>(count, t, section, line,
                             [&] { return c_.integer("an index", LLONG_MIN / 2, LLONG_MAX / 2); });
  }

  /// 5.1's OFFSETS or CONNECTIVITY array of `count` values, on its own keyword line.
  std::vector<long long> array_after(const char* keyword, long long count, const char* section) {
    if (!next_keyword()) fail(c_.line(), std::string(section) + ": the file ends before its " + keyword + " array");
    const long long line = c_.line();
    if (upper(c_.token()) != keyword) fail(line, std::string(section) + ": expected its " + keyword + " array");
    const DataType t = data_type(c_, c_.token());
    c_.end_line(std::string(" after ") + keyword + " type");
    return integers(count, t, keyword, line);
  }

  /// A FIELD's arrays, each read past; in cell data (`cells`: the number of cells) one named as
  /// groups (is_vtk_group_array) of one value a cell becomes the groups.
  void skip_field(long long cells = -1) {
    c_.token();  // the field's name
    const long long arrays = c_.integer("the number of arrays", 0, 1 << 20);
    c_.end_line(" after FIELD name n");
    for (long long a = 0; a < arrays; ++a) {
      if (!next_keyword()) fail(c_.line(), "FIELD: the file ends before its array " + std::to_string(a));
      const long long line = c_.line();
      const std::string name(c_.token());
      const long long comps = c_.integer("the number of components", 1, 1 << 20);
      const long long tuples = c_.integer("the number of tuples", 0, INT32_MAX);
      const DataType t = data_type(c_, c_.token());
      c_.end_line(" after a FIELD array's name, components, tuples and type");
      if (cells >= 0 && comps == 1 && groups_name_.empty() && detail::is_vtk_group_array(name)) {
        take_groups_array(name, tuples, t, "FIELD", line);
      } else if (t.real) {
        reals(comps * tuples, t, "FIELD", line);
      } else {
        integers(comps * tuples, t, "FIELD", line);
      }
    }
  }

  /// A cell array named as groups (is_vtk_group_array), of `count` values of an integer or a float
  /// type, as the groups that take_groups gives the tets. A value read that is no group tag (a NaN,
  /// a fraction) is refused there, naming its cell, whatever its cell's type.
  void take_groups_array(const std::string& name, long long count, const DataType& t, const char* section, long long line) {
    const std::string in = " (" + printable(name) + ")";
    groups_ = values<double>(count, t, section, line, [&] {
      return t.real ? c_.real("a group tag", in, false) : static_cast<double>(c_.integer("a group tag", LLONG_MIN / 2, LLONG_MAX / 2, in));
    });
    groups_name_ = name;
    groups_line_ = line;
  }

  /// CELL_DATA and POINT_DATA to the end of the file: the attributes are read past, and the first
  /// cell array of one component that is_vtk_group_array names becomes the tets' groups. An
  /// attribute of another kind ends the reading (the mesh is complete without it).
  void attributes(std::string key) {
    while (true) {
      const bool cell = key == "CELL_DATA";
      const long long n = c_.integer(cell ? "the number of cells" : "the number of points", 0, INT32_MAX - 1);
      c_.end_line(" after " + key + " n");
      while (true) {
        if (!next_keyword()) return;
        const long long line = c_.line();
        key = upper(c_.token());
        if (key == "CELL_DATA" || key == "POINT_DATA") break;
        if (key == "METADATA") {
          skip_metadata();
        } else if (key == "FIELD") {
          skip_field(cell ? n : -1);
        } else if (key == "SCALARS") {
          const std::string name(c_.token());
          const DataType t = data_type(c_, c_.token());
          const long long comps = c_.at_eol() ? 1 : c_.integer("the number of components", 1, 4);
          c_.end_line(" after SCALARS name type components");
          if (!next_keyword() || upper(c_.token()) != "LOOKUP_TABLE") fail(c_.line(), "SCALARS " + printable(name) + ": expected LOOKUP_TABLE");
          c_.next_line();
          if (cell && comps == 1 && groups_name_.empty() && detail::is_vtk_group_array(name)) {
            take_groups_array(name, n, t, "SCALARS", line);
          } else if (t.real) {
            reals(comps * n, t, "SCALARS", line);
          } else {
            integers(comps * n, t, "SCALARS", line);
          }
        } else if (key == "VECTORS" || key == "NORMALS" || key == "TENSORS" || key == "GLOBAL_IDS" || key == "PEDIGREE_IDS") {
          c_.token();  // the name
          const DataType t = data_type(c_, c_.token());
          c_.end_line(" after " + key + " name type");
          const long long per = key == "TENSORS" ? 9 : (key == "GLOBAL_IDS" || key == "PEDIGREE_IDS") ? 1 : 3;
          if (t.real) reals(per * n, t, key.c_str(), line);
          else integers(per * n, t, key.c_str(), line);
        } else {
          return;  // LOOKUP_TABLE, COLOR_SCALARS, TEXTURE_COORDINATES, ...: no group comes after them
        }
      }
    }
  }

  /// The tets' groups from the group array, one value a cell (by each tet's cell number): tags >= 0
  /// (is_vtk_group_tag), unnamed. Every cell's value is checked, in the file's order, that of a
  /// cell read past (a vertex, a line, a triangle: `types` gives each cell's type) as a tet's.
  void take_groups(const std::vector<long long>& types) {
    if (groups_.size() != types.size())
      fail(groups_line_, groups_name_ + ": " + std::to_string(groups_.size()) + " values for the " + std::to_string(types.size()) +
                             " cells (CELL_DATA counts every cell)");
    for (std::size_t cell = 0; cell < groups_.size(); ++cell) {
      const long long c = static_cast<long long>(cell);
      if (!detail::is_vtk_group_tag(groups_[cell]))
        fail(groups_line_, detail::not_a_group_tag(types[cell] == detail::kVtkTet ? "cell " + std::to_string(c)
                                                                                  : detail::vtk_other_cell(c, types[cell]),
                                                   printable(groups_name_), groups_[cell]));
    }
    for (std::size_t i = 0; i < mesh_.tets.size(); ++i)
      mesh_.tet_group[i] = static_cast<int>(groups_[static_cast<std::size_t>(mesh_.file_tet_ids[i])]);
  }

  void skip_metadata() {
    c_.next_line();
    while (!c_.at_end() && !c_.at_eol()) c_.next_line();
  }

  /// The tets from the cells; cells of a lower dimension (vertices, lines, triangles, quads, ...)
  /// skipped, a volume cell of another kind refused with its count.
  void build(const std::vector<long long>& cells, const std::vector<long long>& offsets, bool offsets_form,
             long long legacy_cells, const std::vector<long long>& types, long long line) {
    const long long n = offsets_form ? static_cast<long long>(offsets.size()) - 1 : legacy_cells;
    if (offsets_form && offsets.empty()) fail(line, "CELLS: no OFFSETS (5.1 writes one more than the cells)");
    if (static_cast<long long>(types.size()) != n)
      fail(line, "CELLS lists " + std::to_string(n) + " cells, CELL_TYPES " + std::to_string(types.size()));
    const long long nv = static_cast<long long>(mesh_.vertices.size());
    std::vector<long long> other(100, 0);
    std::size_t at = 0;  // legacy: the position of the next cell's count
    for (long long i = 0; i < n; ++i) {
      long long begin = 0, count = 0;
      if (offsets_form) {
        begin = offsets[static_cast<std::size_t>(i)];
        const long long end = offsets[static_cast<std::size_t>(i + 1)];
        if (begin < 0 || end < begin || end > static_cast<long long>(cells.size()))
          fail(line, "cell " + std::to_string(i) + ": OFFSETS " + std::to_string(begin) + ".." + std::to_string(end) +
                         " is not a range of the " + std::to_string(cells.size()) + " CONNECTIVITY entries");
        count = end - begin;
      } else {
        if (at >= cells.size()) fail(line, "CELLS: the list ends at cell " + std::to_string(i) + " of " + std::to_string(n));
        count = cells[at];
        begin = static_cast<long long>(at) + 1;
        if (count < 0 || begin + count > static_cast<long long>(cells.size()))
          fail(line, "cell " + std::to_string(i) + ": " + std::to_string(count) + " points run past the CELLS list's size");
        at = static_cast<std::size_t>(begin + count);
      }
      const long long type = types[static_cast<std::size_t>(i)];
      if (type != detail::kVtkTet) {
        if (type >= 0 && type < static_cast<long long>(other.size())) ++other[static_cast<std::size_t>(type)];
        else fail(line, "cell " + std::to_string(i) + ": unknown cell type " + std::to_string(type));
        continue;
      }
      if (count != 4)
        fail(line, "cell " + std::to_string(i) + " (a tetrahedron, type 10) has " + std::to_string(count) +
                       " points, expected 4");
      Tet v{};
      for (int k = 0; k < 4; ++k) {
        const long long id = cells[static_cast<std::size_t>(begin + k)];
        if (id < 0 || id >= nv)
          fail(line, "cell " + std::to_string(i) + ": point index " + std::to_string(id) + " is out of range [0, " +
                         std::to_string(nv) + ")");
        v[static_cast<std::size_t>(k)] = static_cast<int>(id);
      }
      mesh_.tets.push_back(v);
      mesh_.file_tet_ids.push_back(i);
    }
    if (!offsets_form && at != cells.size())
      fail(line, "CELLS: its size says " + std::to_string(cells.size()) + " entries, its cells use " + std::to_string(at));
    std::string refused;
    for (std::size_t t = 0; t < other.size(); ++t)
      if (other[t] > 0)
        if (const char* name = detail::vtk_volume_cell(static_cast<long long>(t))) {
          refused += (refused.empty() ? "" : ", ") + std::to_string(other[t]) + " " + name;
        }
    if (!refused.empty())
      fail(line, "the volume holds " + refused + " besides its " + std::to_string(mesh_.tets.size()) +
                     " tetrahedra: the physical mesh is 4-node tets only (mesh with tets only, first order)");
    if (mesh_.tets.empty()) fail(line, "no tetrahedra (cell type 10) among the " + std::to_string(n) + " cells");
    mesh_.tet_group.assign(mesh_.tets.size(), 0);
    mesh_.file_node_ids.resize(mesh_.vertices.size());
    for (std::size_t i = 0; i < mesh_.vertices.size(); ++i) mesh_.file_node_ids[i] = static_cast<long long>(i);
  }

  std::string bytes_;
  TextCursor c_;
  TetMesh mesh_;
  int version_ = 0;
  bool binary_ = false;
  long long points_line_ = 0;  ///< the POINTS section's line (0: none yet)
  std::vector<double> groups_;  ///< each cell's group, from the cell array groups_name_ ("": none)
  std::string groups_name_;
  long long groups_line_ = 0;
};

}  // namespace

TetMesh read_vtk(const std::filesystem::path& file) {
  std::string bytes = detail::read_file_bytes(file);
  return VtkParser(file, std::move(bytes)).parse();
}

SurfaceMesh read_vtk_surface(const std::filesystem::path& file) {
  std::string bytes = detail::read_file_bytes(file);
  return VtkParser(file, std::move(bytes)).parse_surface();
}

TetMesh read_tet_mesh(const std::filesystem::path& file) {
  const std::string ext = lower_extension(file);
  if (ext == ".vtk") return read_vtk(file);
  if (ext == ".mesh" || ext == ".meshb") return read_medit(file);
  if (ext == ".node" || ext == ".ele") return read_tetgen(file);
  if (ext == ".vtu" || ext == ".pvtu" || ext == ".vtp") return read_vtu(file);  // a .vtp is named as a surface
  if (ext == ".msh") return read_msh(file);
  constexpr const char* kRead = "a .msh (Gmsh), .vtk or .vtu (VTK), .mesh (Medit) or .node/.ele (TetGen) file";
  detail::open_input_file(file);  // a file that is missing, unfinished or unreadable is named so first
  if (ext == ".stl" || ext == ".obj" || ext == ".ply" || ext == ".off") {
    const std::string kind = ext == ".stl" ? "an STL" : ext == ".obj" ? "a Wavefront OBJ" : ext == ".ply" ? "a PLY" : "an OFF";
    throw InputError(file.string() + ": " + kind + " file holds no tetrahedra (a surface" +
                     (ext == ".off" ? "" : ": it can be the virtual mesh") +
                     "): the physical mesh is a volume of tets: mesh the surface first (gmsh -3, tetgen) to " + kRead);
  }
  throw InputError(file.string() + ": " +
                   (ext.empty() ? std::string("no extension to tell its format") : "extension '" + printable(ext) + "' names no format read") +
                   ": a physical mesh is " + kRead);
}

}  // namespace ebh
