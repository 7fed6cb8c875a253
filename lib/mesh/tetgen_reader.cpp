// TetGen reader for the physical mesh: a .node file with its .ele beside it (and a .face, where there
// is one). Format reference: H. Si, "TetGen user's manual", section 5.2 (files .node, .ele, .face).
// A record is one line; `#` starts a comment; node numbers start at 0 or 1 (`-z`), the same in
// every file of the mesh.
#include <cctype>
#include <climits>
#include <cmath>
#include <map>
#include <string>
#include <system_error>
#include <vector>

#include "core/error.hpp"
#include "core/file_names.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/text_cursor.hpp"

namespace ebh {
namespace {

namespace fs = std::filesystem;
using detail::printable;
using detail::TextCursor;

/// One of the mesh's files, read record by record (a record per line, comments skipped).
class TetgenFile {
 public:
  explicit TetgenFile(const fs::path& file) : bytes_(detail::read_file_bytes(file)), c_(file, bytes_) {}

  TextCursor& cursor() { return c_; }

  /// The next record's values up to its line's end or a `#` comment (the cursor stays on its line,
  /// so that an error in it names the line); `what` names it for the error at the file's end.
  std::vector<std::string_view> expect_record(const std::string& what) {
    if (started_) c_.next_line();
    started_ = true;
    const std::string_view first = c_.word();  // blank and comment lines skipped
    if (first.empty()) c_.fail("the file ends before " + what + " (cut short?)");
    std::vector<std::string_view> v{first};
    for (std::string_view t = c_.token(); !t.empty() && !t.starts_with('#'); t = c_.token()) v.push_back(t);
    return v;
  }

 private:
  std::string bytes_;
  TextCursor c_;
  bool started_ = false;  ///< a record was read: the next starts on a later line
};

class TetgenReader {
 public:
  TetgenReader(const fs::path& node, const fs::path& ele, const fs::path& face)
      : node_file_(node), ele_file_(ele), face_file_(face) {}

  TetMesh read() {
    read_nodes();
    read_tets();
    if (!face_file_.empty()) read_faces();
    mesh_.file_node_ids.resize(mesh_.vertices.size());
    for (std::size_t i = 0; i < mesh_.vertices.size(); ++i) mesh_.file_node_ids[i] = static_cast<long long>(i) + base_;
    return std::move(mesh_);
  }

 private:
  /// A record's number: the first one of the .node sets the base, every record follows the one before.
  long long number(TextCursor& c, std::string_view t, long long expected, const char* what) {
    const long long n = c.to_integer(t, what, LLONG_MIN / 2, LLONG_MAX / 2);
    if (n != expected)
      c.fail(std::string(what) + " " + std::to_string(n) + " where " + std::to_string(expected) +
             " comes next (TetGen numbers its records consecutively from 0 or 1)");
    return n;
  }

  static void values(TextCursor& c, const std::vector<std::string_view>& v, std::size_t least, std::size_t most,
                     const std::string& what) {
    if (v.size() < least || v.size() > most)
      c.fail(what + ": " + std::to_string(v.size()) + " values, expected " + std::to_string(least) +
             (least == most ? "" : " to " + std::to_string(most)));
  }

  /// A file's record count (the first value of its first line), checked against what the rest of
  /// the file can hold: records of `least` bytes at least.
  static long long record_count(TextCursor& c, std::string_view t, const char* records, std::size_t least) {
    const long long n = c.to_integer(t, ("the number of " + std::string(records)).c_str(), 0, INT32_MAX - 1);
    if (static_cast<std::size_t>(n) > c.remaining() / least + 1)
      c.fail(std::to_string(n) + " " + records + " do not fit in the rest of the file (" + std::to_string(c.remaining()) +
             " bytes): cut short?");
    return n;
  }

  void read_nodes() {
    TetgenFile f(node_file_);
    TextCursor& c = f.cursor();
    const auto head = f.expect_record("its first line (points, dimension, attributes, boundary markers)");
    values(c, head, 1, 4, "the first line (points, dimension, attributes, boundary markers)");
    const long long n = record_count(c, head[0], "points", 8);
    if (n == 0) c.fail("0 points: the mesh's nodes are in this file (a .node written with -N has none)");
    const long long dim = head.size() > 1 ? c.to_integer(head[1], "the dimension", 2, 3) : 3;
    if (dim != 3) c.fail("dimension 2: a plane mesh holds no tetrahedra (the physical mesh is a volume)");
    const long long attrs = head.size() > 2 ? c.to_integer(head[2], "the number of attributes", 0, 1 << 20) : 0;
    const long long markers = head.size() > 3 ? c.to_integer(head[3], "the boundary markers flag", 0, 1) : 0;
    const std::size_t per = static_cast<std::size_t>(4 + attrs + markers);
    mesh_.vertices.resize(static_cast<std::size_t>(n));
    for (long long i = 0; i < n; ++i) {
      const auto v = f.expect_record("point " + std::to_string(i + 1) + " of " + std::to_string(n));
      values(c, v, per, per, "a point (number, x, y, z, " + std::to_string(attrs) + " attributes, " +
                                 std::to_string(markers) + " marker)");
      if (i == 0) {
        base_ = c.to_integer(v[0], "the first point's number", 0, 1);
      }
      number(c, v[0], base_ + i, "point");
      Vec3d& p = mesh_.vertices[static_cast<std::size_t>(i)];
      p.x = c.to_real(v[1], "a coordinate");
      p.y = c.to_real(v[2], "a coordinate");
      p.z = c.to_real(v[3], "a coordinate");
    }
  }

  /// A node number of an element, as a 0-based index.
  int node(TextCursor& c, std::string_view t) const {
    const long long nv = static_cast<long long>(mesh_.vertices.size());
    return static_cast<int>(c.to_integer(t, "a node number", base_, base_ + nv - 1, " (the .node's numbers)") - base_);
  }

  /// A region attribute or boundary marker as a group tag: a whole number >= 0.
  static int tag(TextCursor& c, std::string_view t, const char* what) {
    const double a = c.to_real(t, what);
    if (a < 0 || a > INT32_MAX / 2 || a != std::floor(a))
      c.fail(std::string(what) + " " + printable(t) + " is not a group tag (a whole number >= 0)");
    return static_cast<int>(a);
  }

  void read_tets() {
    TetgenFile f(ele_file_);
    TextCursor& c = f.cursor();
    const auto head = f.expect_record("its first line (tetrahedra, nodes per tetrahedron, attributes)");
    values(c, head, 1, 3, "the first line (tetrahedra, nodes per tetrahedron, attributes)");
    const long long n = record_count(c, head[0], "tetrahedra", 10);
    if (n == 0) c.fail("0 tetrahedra: the physical mesh is a volume of 4-node tets");
    const long long corners = head.size() > 1 ? c.to_integer(head[1], "the nodes per tetrahedron", 4, 10) : 4;
    if (corners != 4)
      c.fail(std::to_string(corners) + " nodes per tetrahedron: the physical mesh is 4-node tets only (mesh without "
                                       "-o2, first order)");
    const long long attrs = head.size() > 2 ? c.to_integer(head[2], "the number of attributes", 0, 1 << 20) : 0;
    const std::size_t per = static_cast<std::size_t>(5 + attrs);
    mesh_.tets.resize(static_cast<std::size_t>(n));
    mesh_.tet_group.assign(static_cast<std::size_t>(n), 0);
    mesh_.file_tet_ids.resize(static_cast<std::size_t>(n));
    for (long long i = 0; i < n; ++i) {
      const auto v = f.expect_record("tetrahedron " + std::to_string(i + 1) + " of " + std::to_string(n));
      values(c, v, per, per, "a tetrahedron (number, 4 nodes, " + std::to_string(attrs) + " attributes)");
      mesh_.file_tet_ids[static_cast<std::size_t>(i)] = number(c, v[0], base_ + i, "tetrahedron");
      for (int k = 0; k < 4; ++k) mesh_.tets[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] = node(c, v[1 + k]);
      if (attrs > 0) mesh_.tet_group[static_cast<std::size_t>(i)] = tag(c, v[5], "the region attribute");
    }
  }

  /// The boundary faces and their markers, as groups named surface_N on tags after every tet's
  /// (a face of marker 0 in none). Values after a face's marker (`-nn`: its two tets) are not read.
  void read_faces() {
    TetgenFile f(face_file_);
    TextCursor& c = f.cursor();
    const auto head = f.expect_record("its first line (faces, boundary markers)");
    values(c, head, 1, 2, "the first line (faces, boundary markers)");
    const long long n = record_count(c, head[0], "faces", 8);
    const long long markers = head.size() > 1 ? c.to_integer(head[1], "the boundary markers flag", 0, 1) : 0;
    int top = 0;
    for (int g : mesh_.tet_group) top = std::max(top, g);
    std::map<int, int> surface_tag;  // marker -> its group's tag, in order of the markers
    std::vector<int> marker(static_cast<std::size_t>(n), 0);
    mesh_.triangles.resize(static_cast<std::size_t>(n));
    for (long long i = 0; i < n; ++i) {
      const auto v = f.expect_record("face " + std::to_string(i + 1) + " of " + std::to_string(n));
      values(c, v, static_cast<std::size_t>(4 + markers), static_cast<std::size_t>(6 + markers),
             "a face (number, 3 nodes, " + std::to_string(markers) + " marker)");
      number(c, v[0], base_ + i, "face");
      for (int k = 0; k < 3; ++k) mesh_.triangles[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] = node(c, v[1 + k]);
      if (markers) marker[static_cast<std::size_t>(i)] = tag(c, v[4], "the boundary marker");
      if (marker[static_cast<std::size_t>(i)] != 0) surface_tag.emplace(marker[static_cast<std::size_t>(i)], 0);
    }
    // A face of marker 0 is in no group (TetGen's -f lists every inner face so): not kept.
    std::size_t kept = 0;
    for (std::size_t i = 0; i < marker.size(); ++i)
      if (marker[i] != 0) {
        mesh_.triangles[kept] = mesh_.triangles[i];
        marker[kept++] = marker[i];
      }
    mesh_.triangles.resize(kept);
    marker.resize(kept);
    for (auto& [m, t] : surface_tag) {
      t = ++top;
      mesh_.group_names[t] = "surface_" + std::to_string(m);
      mesh_.group_file_tags[t] = m;
    }
    mesh_.triangle_group.resize(kept);
    for (std::size_t i = 0; i < kept; ++i) mesh_.triangle_group[i] = surface_tag[marker[i]];
  }

  fs::path node_file_, ele_file_, face_file_;
  TetMesh mesh_;
  long long base_ = 0;
};

std::string upper_ascii(std::string s) {
  for (char& ch : s) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  return s;
}

}  // namespace

namespace {

/// The TetGen files of the mesh `file` names: its .node, .ele and .face (empty where there is none).
struct TetgenFiles {
  fs::path node, ele, face;
};

TetgenFiles tetgen_files(const fs::path& file) {
  const std::string ext = lower_extension(file);
  if (ext != ".node" && ext != ".ele") throw InputError(file.string() + ": a TetGen mesh is read from its .node or .ele file");
  // The other files' extensions in the case of the one given (a Windows copy: MESH.NODE, MESH.ELE).
  const bool upper = file.extension().string() != ext;
  auto beside = [&](const char* e) { return fs::path(file).replace_extension(upper ? upper_ascii(e) : std::string(e)); };
  TetgenFiles f{beside(".node"), beside(".ele"), beside(".face")};
  std::error_code ec;
  if (!fs::exists(f.face, ec)) f.face.clear();
  return f;
}

}  // namespace

TetMesh read_tetgen(const fs::path& file) {
  const TetgenFiles f = tetgen_files(file);
  std::error_code ec;
  for (const fs::path& p : {f.node, f.ele})
    if (!fs::exists(p, ec))
      throw InputError(file.string() + ": no " + p.filename().string() +
                       " beside it (a TetGen mesh is its .node and .ele files, written by `tetgen` side by side)");
  return TetgenReader(f.node, f.ele, f.face).read();
}

std::vector<fs::path> tet_mesh_companions(const fs::path& file) {
  const std::string ext = lower_extension(file);
  if (ext != ".node" && ext != ".ele") return {};
  const TetgenFiles f = tetgen_files(file);
  std::vector<fs::path> out;
  for (const fs::path& p : {f.node, f.ele, f.face})
    if (!p.empty() && p != file) out.push_back(p);
  return out;
}

}  // namespace ebh
