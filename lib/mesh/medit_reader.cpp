// Medit ASCII reader for the physical mesh (.mesh): what MMG, CGAL's Mesh_3, TetGen (-g), SOFA and
// meshio write. Format reference: P. Frey, "MEDIT: an interactive mesh visualization software",
// INRIA RT-0253 (2001), appendix "The mesh file format", and libMeshb's keyword table.
#include <cctype>
#include <climits>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/text_cursor.hpp"

namespace ebh {
namespace {

using detail::printable;
using detail::TextCursor;

/// A keyword whose records the reader reads past: how many numbers a record holds.
struct Skipped {
  const char* keyword;
  int per_record;
};
constexpr Skipped kSkipped[] = {
    {"edges", 3},           {"quadrilaterals", 5},       {"corners", 1},          {"ridges", 1},
    {"requiredvertices", 1}, {"requirededges", 1},       {"requiredtriangles", 1}, {"requiredquadrilaterals", 1},
    {"requiredtetrahedra", 1}, {"normals", 3},           {"normalatvertices", 2}, {"normalattrianglevertices", 3},
    {"normalatquadrilateralvertices", 3}, {"tangents", 3}, {"tangentatvertices", 2}, {"tangentatedges", 3},
    {"edgesp2", 4},         {"trianglesp2", 7},          {"quadrilateralsq2", 10}, {"subdomainfromgeom", 4},
};

/// A volume element other than the 4-node tet, named for messages: refused with its count.
struct Volume {
  const char* keyword;
  int per_record;
  const char* many;
};
constexpr Volume kVolumes[] = {
    {"hexahedra", 9, "hexahedra"},         {"prisms", 7, "prisms"},
    {"pyramids", 6, "pyramids"},           {"tetrahedrap2", 11, "10-node tetrahedra"},
    {"hexahedraq2", 28, "27-node hexahedra"},
};

std::string lower(std::string_view s) {
  std::string l(s);
  for (char& c : l) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return l;
}

class MeditParser {
 public:
  MeditParser(const std::filesystem::path& file, std::string bytes) : bytes_(std::move(bytes)), c_(file, bytes_) {}

  TetMesh parse() {
    header();
    std::vector<Tet> tets;
    std::vector<long long> tet_refs, tri_refs;
    std::vector<Tri> tris;
    std::map<std::string, long long> refused;  // volume elements of other kinds: name -> count
    long long tets_line = 0, tris_line = 0;
    bool ended = false;
    while (true) {
      const std::string_view w = c_.word();
      if (w.empty()) break;
      const long long line = c_.line();
      const std::string key = lower(w);
      if (key == "end") {
        ended = true;
        break;
      }
      if ((key == "vertices" && have_vertices_) || (key == "tetrahedra" && tets_line) || (key == "triangles" && tris_line)) {
        c_.fail_at(line, "a second " + printable(w) + " section");
      } else if (key == "vertices") {
        const long long n = count(key, 4);
        mesh_.vertices.resize(static_cast<std::size_t>(n));
        for (long long i = 0; i < n; ++i) {
          Vec3d& p = mesh_.vertices[static_cast<std::size_t>(i)];
          p.x = real("a coordinate", "Vertices", i);
          p.y = real("a coordinate", "Vertices", i);
          p.z = real("a coordinate", "Vertices", i);
          real("a vertex reference", "Vertices", i);  // its ref: a number, unused
        }
        have_vertices_ = true;
      } else if (key == "tetrahedra") {
        tets_line = line;
        const long long n = count(key, 5);
        tets.resize(static_cast<std::size_t>(n));
        tet_refs.resize(static_cast<std::size_t>(n));
        for (long long i = 0; i < n; ++i) {
          for (int k = 0; k < 4; ++k) tets[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] = vertex("Tetrahedra", i);
          tet_refs[static_cast<std::size_t>(i)] = ref("Tetrahedra", i);
        }
      } else if (key == "triangles") {
        tris_line = line;
        const long long n = count(key, 4);
        tris.resize(static_cast<std::size_t>(n));
        tri_refs.resize(static_cast<std::size_t>(n));
        for (long long i = 0; i < n; ++i) {
          for (int k = 0; k < 3; ++k) tris[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] = vertex("Triangles", i);
          tri_refs[static_cast<std::size_t>(i)] = ref("Triangles", i);
        }
      } else if (key == "dimension") {
        c_.fail_at(line, "a second Dimension keyword");
      } else if (const Volume* v = volume(key)) {
        const long long n = count(key, v->per_record);
        skip(n * v->per_record, w);
        refused[v->many] += n;
      } else if (const Skipped* s = skipped(key)) {
        skip(count(key, s->per_record) * s->per_record, w);
      } else {
        c_.fail_at(line, "unknown keyword '" + printable(w) +
                             "' (a Medit .mesh holds Vertices, Triangles, Tetrahedra, ... and ends with End)");
      }
    }
    if (!ended) c_.fail("the file ends without End (cut short?)");
    if (!have_vertices_) c_.fail("no Vertices section");
    std::string others;
    for (const auto& [name, n] : refused)
      if (n > 0) others += (others.empty() ? "" : ", ") + std::to_string(n) + " " + name;
    if (!others.empty())
      c_.fail_at(tets_line ? tets_line : c_.line(),
                 "the volume holds " + others + " besides its " + std::to_string(tets.size()) +
                     " tetrahedra: the physical mesh is 4-node tets only (mesh with tets only, first order)");
    if (tets.empty()) c_.fail("no Tetrahedra: the physical mesh is a volume of 4-node tets");
    build(tets, tet_refs, tris, tri_refs);
    return std::move(mesh_);
  }

 private:
  void header() {
    const long long line = c_.line();
    const std::string_view first = c_.word();
    if (first.empty()) c_.fail_at(line, "empty file");
    if (lower(first) != "meshversionformatted")
      c_.fail_at(c_.line(), "not a Medit mesh (it starts with '" + printable(first) +
                                "', not MeshVersionFormatted): a binary .meshb is not read, write the mesh as ASCII "
                                ".mesh");
    c_.to_integer(c_.word(), "the format version", 1, 4);  // 1: floats, 2: doubles, 3-4: 64-bit ints (binary only)
    const std::string_view dim = c_.word();
    if (lower(dim) != "dimension") c_.fail("expected Dimension after MeshVersionFormatted, got '" + printable(dim) + "'");
    const long long d = c_.to_integer(c_.word(), "the dimension", 2, 3);
    if (d != 3) c_.fail("Dimension 2: a plane mesh holds no tetrahedra (the physical mesh is a volume)");
  }

  static const Volume* volume(const std::string& key) {
    for (const Volume& v : kVolumes)
      if (key == v.keyword) return &v;
    return nullptr;
  }
  static const Skipped* skipped(const std::string& key) {
    for (const Skipped& s : kSkipped)
      if (key == s.keyword) return &s;
    return nullptr;
  }

  /// A section's record count, checked against what the rest of the file can hold (`per_record`
  /// numbers of 2 bytes at least, "0 ").
  long long count(const std::string& key, int per_record) {
    const long long n = c_.to_integer(c_.word(), "a record count", 0, INT32_MAX - 1, " (after " + key + ")");
    if (static_cast<std::size_t>(n) > c_.remaining() / (2 * static_cast<std::size_t>(per_record)) + 1)
      c_.fail(key + ": " + std::to_string(n) + " records do not fit in the rest of the file (" +
              std::to_string(c_.remaining()) + " bytes): cut short?");
    return n;
  }

  std::string context(const char* section, long long i) const {
    return std::string(" (") + section + " record " + std::to_string(i + 1) + ")";
  }

  double real(const char* what, const char* section, long long i) {
    const std::string_view t = c_.word();
    if (t.empty()) c_.fail(std::string(section) + ": the file ends in record " + std::to_string(i + 1));
    return c_.to_real(t, what, context(section, i));
  }

  /// A 1-based vertex number, as a 0-based index.
  int vertex(const char* section, long long i) {
    const std::string_view t = c_.word();
    if (t.empty()) c_.fail(std::string(section) + ": the file ends in record " + std::to_string(i + 1));
    if (!have_vertices_) c_.fail(std::string(section) + " before Vertices");
    const long long nv = static_cast<long long>(mesh_.vertices.size());
    return static_cast<int>(c_.to_integer(t, "a vertex number", 1, nv, context(section, i)) - 1);
  }

  /// An element's reference: its group tag (>= 0).
  long long ref(const char* section, long long i) {
    const std::string_view t = c_.word();
    if (t.empty()) c_.fail(std::string(section) + ": the file ends in record " + std::to_string(i + 1));
    return c_.to_integer(t, "a reference (group tag, >= 0)", 0, INT32_MAX / 2, context(section, i));
  }

  void skip(long long numbers, std::string_view key) {
    for (long long k = 0; k < numbers; ++k)
      if (c_.word().empty()) c_.fail(printable(key) + ": the file ends inside the section (cut short?)");
  }

  /// The mesh from the records: the tets' references are their groups (unnamed, a pin names them
  /// by number), the triangles' references groups named surface_N on tags after every tet's.
  void build(std::vector<Tet>& tets, const std::vector<long long>& tet_refs, const std::vector<Tri>& tris,
             const std::vector<long long>& tri_refs) {
    mesh_.tets = std::move(tets);
    mesh_.tet_group.resize(tet_refs.size());
    long long top = 0;
    for (std::size_t i = 0; i < tet_refs.size(); ++i) {
      mesh_.tet_group[i] = static_cast<int>(tet_refs[i]);
      top = std::max(top, tet_refs[i]);
    }
    std::map<long long, int> surface_tag;  // triangle ref -> its group's tag
    for (long long r : tri_refs)
      if (r != 0) surface_tag.emplace(r, 0);
    for (auto& [r, tag] : surface_tag) {
      tag = static_cast<int>(++top);
      mesh_.group_names[tag] = "surface_" + std::to_string(r);
      mesh_.group_file_tags[tag] = static_cast<int>(r);
    }
    // A triangle of reference 0 is in no group: not kept (the triangles serve the pins by group).
    for (std::size_t i = 0; i < tri_refs.size(); ++i)
      if (tri_refs[i] != 0) {
        mesh_.triangles.push_back(tris[i]);
        mesh_.triangle_group.push_back(surface_tag[tri_refs[i]]);
      }
    mesh_.file_node_ids.resize(mesh_.vertices.size());
    for (std::size_t i = 0; i < mesh_.vertices.size(); ++i) mesh_.file_node_ids[i] = static_cast<long long>(i) + 1;
    mesh_.file_tet_ids.resize(mesh_.tets.size());
    for (std::size_t i = 0; i < mesh_.tets.size(); ++i) mesh_.file_tet_ids[i] = static_cast<long long>(i) + 1;
  }

  std::string bytes_;
  TextCursor c_;
  TetMesh mesh_;
  bool have_vertices_ = false;
};

}  // namespace

TetMesh read_medit(const std::filesystem::path& file) {
  std::string bytes = detail::read_file_bytes(file);
  return MeditParser(file, std::move(bytes)).parse();
}

}  // namespace ebh
