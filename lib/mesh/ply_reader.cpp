// PLY surface reader (ASCII and binary, either byte order): a virtual-mesh surface as 3D Slicer,
// MeshLab, Blender and Open3D export it. Format reference: G. Turk, "The PLY Polygon File Format"
// (1994), and the type names of later writers (int8 .. float64).
#include <climits>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "mesh/binary_values.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/polygon.hpp"
#include "mesh/text_cursor.hpp"

namespace ebh {
namespace {

using detail::printable;
using detail::TextCursor;

struct PlyType {
  int bytes = 0;
  bool real = false, is_signed = true;
};

/// A property: a scalar, or a list (its count's type, then its items').
struct Property {
  std::string name;
  PlyType type;
  bool list = false;
  PlyType count;
};

struct Element {
  std::string name;
  long long count = 0;
  long long line = 0;
  std::vector<Property> props;
};

class PlyParser {
 public:
  PlyParser(const std::filesystem::path& file, std::string bytes) : bytes_(std::move(bytes)), c_(file, bytes_) {}

  SurfaceMesh parse() {
    header();
    for (const Element& e : elements_) {
      if (e.name == "vertex") vertices(e);
      else if (e.name == "face") faces(e);
      else
        for (long long i = 0; i < e.count; ++i) record(e, nullptr);  // edges, materials, ...: read past
    }
    if (!have_vertices_) c_.fail_at(1, "no 'element vertex' in the header");
    if (mesh_.triangles.empty()) c_.fail_at(face_line_ ? face_line_ : 1, "no faces: a surface is a list of polygons ('element face')");
    return std::move(mesh_);
  }

 private:
  PlyType type(std::string_view t) const {
    const std::string n(t);
    if (n == "char" || n == "int8") return {1};
    if (n == "uchar" || n == "uint8") return {1, false, false};
    if (n == "short" || n == "int16") return {2};
    if (n == "ushort" || n == "uint16") return {2, false, false};
    if (n == "int" || n == "int32") return {4};
    if (n == "uint" || n == "uint32") return {4, false, false};
    if (n == "float" || n == "float32") return {4, true};
    if (n == "double" || n == "float64") return {8, true};
    c_.fail("unknown property type '" + printable(t) + "' (char, uchar, short, ushort, int, uint, float, double)");
  }

  void header() {
    if (c_.rest_of_line() != "ply") c_.fail_at(1, "not a PLY file (its first line is not 'ply')");
    c_.next_line();
    bool have_format = false;
    while (true) {
      if (c_.at_end()) c_.fail("the header ends without end_header");
      const std::string_view key = c_.token();
      if (key == "end_header") {
        c_.end_line(" after end_header");
        break;
      }
      if (key == "format") {
        const std::string_view f = c_.token();
        if (f == "binary_little_endian") binary_ = 1;
        else if (f == "binary_big_endian") binary_ = 2;
        else if (f != "ascii") c_.fail("unknown format '" + printable(f) + "' (ascii, binary_little_endian or binary_big_endian)");
        c_.token();  // the version, 1.0
        have_format = true;
      } else if (key == "element") {
        Element e;
        e.line = c_.line();
        e.name = std::string(c_.token());
        e.count = c_.integer("the element count", 0, INT32_MAX - 1);
        // Once each: the faces' indices are checked against the one vertex count.
        if (e.name == "vertex" || e.name == "face")
          for (const Element& before : elements_)
            if (before.name == e.name)
              c_.fail("a second 'element " + e.name + "' (the first at line " + std::to_string(before.line) + ")");
        elements_.push_back(std::move(e));
      } else if (key == "property") {
        if (elements_.empty()) c_.fail("a property before any element");
        Property p;
        const std::string_view t = c_.token();
        if (t == "list") {
          p.list = true;
          p.count = type(c_.token());
          if (p.count.real) c_.fail("a list's count type must be an integer type");
          p.type = type(c_.token());
        } else {
          p.type = type(t);
        }
        p.name = std::string(c_.token());
        if (p.name.empty()) c_.fail("a property without a name");
        elements_.back().props.push_back(p);
      } else if (key != "comment" && key != "obj_info" && !key.empty()) {
        c_.fail("unexpected '" + printable(key) + "' in the header (format, element, property, comment, end_header)");
      }
      c_.next_line();
    }
    if (!have_format) c_.fail("the header has no format line");
    data_line_ = c_.line();
  }

  /// One value of type t: from the text (ASCII) or the bytes (binary), as a double.
  double value(const PlyType& t) {
    if (!binary_) {
      const std::string_view w = c_.word();
      if (w.empty()) c_.fail("the file ends inside an element (cut short?)");
      if (t.real) return c_.to_real(w, "a number");
      return static_cast<double>(c_.to_integer(w, "an integer", t.is_signed ? LLONG_MIN / 2 : 0, LLONG_MAX / 2));
    }
    const std::size_t at = c_.position();
    if (bytes_.size() - at < static_cast<std::size_t>(t.bytes))
      c_.fail_at(data_line_, "the binary data ends inside an element (cut short?)");
    const std::uint64_t u = detail::load_bits(bytes_.data() + at, t.bytes, binary_ == 2);
    c_.jump_to(at + static_cast<std::size_t>(t.bytes));
    return t.real ? detail::bits_as_real(u, t.bytes) : static_cast<double>(detail::bits_as_integer(u, t.bytes, t.is_signed));
  }

  /// One element's record: its scalars into `scalars` (by property, NaN for a list) and its last
  /// list into `list` (where given).
  void record(const Element& e, std::vector<double>* scalars, std::vector<long long>* list = nullptr) {
    if (scalars) scalars->assign(e.props.size(), 0.0);
    for (std::size_t k = 0; k < e.props.size(); ++k) {
      const Property& p = e.props[k];
      if (!p.list) {
        const double v = value(p.type);
        if (scalars) (*scalars)[k] = v;
        continue;
      }
      const double n = value(p.count);
      if (n < 0 || n > static_cast<double>(c_.remaining()) + 1)
        c_.fail("a list of " + std::to_string(static_cast<long long>(n)) +
                " items (" + printable(p.name) + ") does not fit in the rest of the file");
      if (list) list->clear();
      for (long long i = 0; i < static_cast<long long>(n); ++i) {
        const double v = value(p.type);
        if (list) list->push_back(static_cast<long long>(v));
      }
    }
  }

  int index_of(const Element& e, std::initializer_list<const char*> names, bool list) const {
    for (std::size_t k = 0; k < e.props.size(); ++k)
      for (const char* n : names)
        if (e.props[k].name == n && e.props[k].list == list) return static_cast<int>(k);
    return -1;
  }

  void vertices(const Element& e) {
    const int x = index_of(e, {"x"}, false), y = index_of(e, {"y"}, false), z = index_of(e, {"z"}, false);
    if (x < 0 || y < 0 || z < 0) c_.fail_at(e.line, "element vertex has no x, y and z properties");
    if (static_cast<std::size_t>(e.count) > c_.remaining() / (binary_ ? 12 : 6) + 1)
      c_.fail_at(e.line, std::to_string(e.count) + " vertices do not fit in the rest of the file (" +
                             std::to_string(c_.remaining()) + " bytes): cut short?");
    std::vector<double> v;
    mesh_.vertices.resize(static_cast<std::size_t>(e.count));
    for (long long i = 0; i < e.count; ++i) {
      record(e, &v);
      const Vec3d p{v[static_cast<std::size_t>(x)], v[static_cast<std::size_t>(y)], v[static_cast<std::size_t>(z)]};
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        fail_record("vertex", i, "a non-finite coordinate");
      mesh_.vertices[static_cast<std::size_t>(i)] = p;
    }
    have_vertices_ = true;
  }

  void faces(const Element& e) {
    face_line_ = e.line;
    const int list = index_of(e, {"vertex_indices", "vertex_index"}, true);
    if (list < 0) c_.fail_at(e.line, "element face has no list property vertex_indices (or vertex_index)");
    for (std::size_t k = static_cast<std::size_t>(list) + 1; k < e.props.size(); ++k)
      if (e.props[k].list) c_.fail_at(e.line, "element face has a list after vertex_indices: not read");
    if (!have_vertices_) c_.fail_at(e.line, "element face comes before element vertex");
    const long long nv = static_cast<long long>(mesh_.vertices.size());
    std::vector<long long> corners;
    for (long long i = 0; i < e.count; ++i) {
      record(e, nullptr, &corners);
      if (corners.size() < 3) fail_record("face", i, std::to_string(corners.size()) + " vertices, a face needs 3 at least");
      for (std::size_t a = 0; a < corners.size(); ++a) {
        if (corners[a] < 0 || corners[a] >= nv)
          fail_record("face", i, "vertex index " + std::to_string(corners[a]) + " is out of range [0, " + std::to_string(nv) + ")");
        for (std::size_t b = a + 1; b < corners.size(); ++b)
          if (corners[a] == corners[b]) fail_record("face", i, "vertex " + std::to_string(corners[a]) + " twice (a degenerate face)");
      }
      if (corners.size() > 3)
        if (const int k = detail::concave_corner(corners, mesh_.vertices); k >= 0)
          fail_record("face", i, detail::concave_message(corners.size(), corners[static_cast<std::size_t>(k)]));
      detail::append_fan(corners, mesh_.triangles);
    }
  }

  /// An error in record i of an element: ASCII names its line, binary the element and the record.
  [[noreturn]] void fail_record(const char* element, long long i, const std::string& what) const {
    if (!binary_) c_.fail(std::string(element) + " " + std::to_string(i) + ": " + what);
    c_.fail_at(data_line_, std::string("binary data, ") + element + " " + std::to_string(i) + ": " + what);
  }

  std::string bytes_;
  TextCursor c_;
  SurfaceMesh mesh_;
  std::vector<Element> elements_;
  int binary_ = 0;  ///< 0 ASCII, 1 little-endian, 2 big-endian
  long long data_line_ = 0, face_line_ = 0;
  bool have_vertices_ = false;
};

}  // namespace

SurfaceMesh read_ply(const std::filesystem::path& file) {
  std::string bytes = detail::read_file_bytes(file);
  return PlyParser(file, std::move(bytes)).parse();
}

}  // namespace ebh
