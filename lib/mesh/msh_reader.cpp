// Gmsh MSH ASCII reader, versions 2.x and 4.1.
// Format references: Gmsh reference manual, "MSH file format" (4.1) and "Legacy formats" (2.2).
#include <algorithm>
#include <array>
#include <climits>
#include <map>
#include <set>
#include <tuple>
#include <utility>

#include "mesh/mesh_io.hpp"
#include "mesh/text_cursor.hpp"

namespace ebh {
namespace {

using detail::printable;
using detail::TextCursor;

constexpr long long kMaxTag = (1LL << 62);  // node / element / entity tags: any 64-bit value Gmsh writes
constexpr int kTypeTriangle = 2;
constexpr int kTypeTet = 4;
constexpr int kTypeTet10 = 11;

/// An element shape of Gmsh (ElementType::getParentType): its dimension, its first-order node
/// count (0: a polygon's or polyhedron's, given per element) and its names for messages.
struct Shape {
  int dim;
  int nodes;
  const char* one;
  const char* many;
};
constexpr Shape kPoint{0, 1, "point", "points"}, kLine{1, 2, "line", "lines"}, kTriangle{2, 3, "triangle", "triangles"},
    kQuadrangle{2, 4, "quadrangle", "quadrangles"}, kPolygon{2, 0, "polygon", "polygons"},
    kTetrahedron{3, 4, "tetrahedron", "tetrahedra"}, kHexahedron{3, 8, "hexahedron", "hexahedra"},
    kPrism{3, 6, "prism", "prisms"}, kPyramid{3, 5, "pyramid", "pyramids"}, kTrihedron{3, 4, "trihedron", "trihedra"},
    kPolyhedron{3, 0, "polyhedron", "polyhedra"};

/// An element type of Gmsh: its number (Common/GmshDefines.h, MSH_*), its shape and its node count
/// (Geo/MElement.cpp, MElement::getInfoMSH), as of Gmsh 4.8. Of these the reader keeps 4-node tets
/// (type 4) and 3-node triangles (type 2); a volume element of another type is refused
/// (check_volume_elements); points, lines and the other surface elements are read past, their
/// nodes checked. A type that is not here (76-78, 138 and 139, which Gmsh neither reads nor
/// writes, above 140) is refused.
struct ElementType {
  int type;
  Shape shape;
  int nodes;
};
constexpr ElementType kElementTypes[] = {
    {1, kLine, 2}, {2, kTriangle, 3}, {3, kQuadrangle, 4}, {4, kTetrahedron, 4}, {5, kHexahedron, 8},
    {6, kPrism, 6}, {7, kPyramid, 5}, {8, kLine, 3}, {9, kTriangle, 6}, {10, kQuadrangle, 9},
    {11, kTetrahedron, 10}, {12, kHexahedron, 27}, {13, kPrism, 18}, {14, kPyramid, 14}, {15, kPoint, 1},
    {16, kQuadrangle, 8}, {17, kHexahedron, 20}, {18, kPrism, 15}, {19, kPyramid, 13}, {20, kTriangle, 9},
    {21, kTriangle, 10}, {22, kTriangle, 12}, {23, kTriangle, 15}, {24, kTriangle, 15}, {25, kTriangle, 21},
    {26, kLine, 4}, {27, kLine, 5}, {28, kLine, 6}, {29, kTetrahedron, 20}, {30, kTetrahedron, 35},
    {31, kTetrahedron, 56}, {32, kTetrahedron, 22}, {33, kTetrahedron, 28}, {34, kPolygon, 0}, {35, kPolyhedron, 0},
    {36, kQuadrangle, 16}, {37, kQuadrangle, 25}, {38, kQuadrangle, 36}, {39, kQuadrangle, 12},
    {40, kQuadrangle, 16}, {41, kQuadrangle, 20}, {42, kTriangle, 28}, {43, kTriangle, 36}, {44, kTriangle, 45},
    {45, kTriangle, 55}, {46, kTriangle, 66}, {47, kQuadrangle, 49}, {48, kQuadrangle, 64}, {49, kQuadrangle, 81},
    {50, kQuadrangle, 100}, {51, kQuadrangle, 121}, {52, kTriangle, 18}, {53, kTriangle, 21}, {54, kTriangle, 24},
    {55, kTriangle, 27}, {56, kTriangle, 30}, {57, kQuadrangle, 24}, {58, kQuadrangle, 28}, {59, kQuadrangle, 32},
    {60, kQuadrangle, 36}, {61, kQuadrangle, 40}, {62, kLine, 7}, {63, kLine, 8}, {64, kLine, 9}, {65, kLine, 10},
    {66, kLine, 11}, {67, kLine, 2}, {68, kTriangle, 3}, {69, kPolygon, 0}, {70, kLine, 2}, {71, kTetrahedron, 84},
    {72, kTetrahedron, 120}, {73, kTetrahedron, 165}, {74, kTetrahedron, 220}, {75, kTetrahedron, 286},
    {79, kTetrahedron, 34}, {80, kTetrahedron, 40}, {81, kTetrahedron, 46}, {82, kTetrahedron, 52},
    {83, kTetrahedron, 58}, {84, kLine, 1}, {85, kTriangle, 1}, {86, kQuadrangle, 1}, {87, kTetrahedron, 1},
    {88, kHexahedron, 1}, {89, kPrism, 1}, {90, kPrism, 40}, {91, kPrism, 75}, {92, kHexahedron, 64},
    {93, kHexahedron, 125}, {94, kHexahedron, 216}, {95, kHexahedron, 343}, {96, kHexahedron, 512},
    {97, kHexahedron, 729}, {98, kHexahedron, 1000}, {99, kHexahedron, 32}, {100, kHexahedron, 44},
    {101, kHexahedron, 56}, {102, kHexahedron, 68}, {103, kHexahedron, 80}, {104, kHexahedron, 92},
    {105, kHexahedron, 104}, {106, kPrism, 126}, {107, kPrism, 196}, {108, kPrism, 288}, {109, kPrism, 405},
    {110, kPrism, 550}, {111, kPrism, 24}, {112, kPrism, 33}, {113, kPrism, 42}, {114, kPrism, 51},
    {115, kPrism, 60}, {116, kPrism, 69}, {117, kPrism, 78}, {118, kPyramid, 30}, {119, kPyramid, 55},
    {120, kPyramid, 91}, {121, kPyramid, 140}, {122, kPyramid, 204}, {123, kPyramid, 285}, {124, kPyramid, 385},
    {125, kPyramid, 21}, {126, kPyramid, 29}, {127, kPyramid, 37}, {128, kPyramid, 45}, {129, kPyramid, 53},
    {130, kPyramid, 61}, {131, kPyramid, 69}, {132, kPyramid, 1}, {133, kPoint, 1}, {134, kLine, 2},
    {135, kTriangle, 3}, {136, kTetrahedron, 4}, {137, kTetrahedron, 16}, {140, kTrihedron, 4},
};

const ElementType* element_type(int type) {
  for (const ElementType& t : kElementTypes)
    if (t.type == type) return &t;
  return nullptr;
}

/// The type's name for messages: "prism", "10-node tetrahedra" (the node count where it is not the
/// first-order shape's).
std::string type_name(const ElementType& t, bool plural) {
  const std::string nodes = t.nodes == t.shape.nodes ? "" : std::to_string(t.nodes) + "-node ";
  return nodes + (plural ? t.shape.many : t.shape.one);
}

/// A volume element that check_volume_elements refuses: not a 4-node tet.
bool other_volume(const ElementType& t) { return t.shape.dim == 3 && t.type != kTypeTet; }

std::string element_ctx(long long id) { return " (element id " + std::to_string(id) + ")"; }
std::string node_ctx(long long id) { return " (node id " + std::to_string(id) + ")"; }

class MshParser {
 public:
  MshParser(const std::filesystem::path& file, std::string_view text) : c_(file, text), file_(file) {}

  TetMesh parse() {
    read_format();
    while (c_.skip_empty_lines()) {
      const long long header_line = c_.line();
      std::string_view head = c_.rest_of_line();
      if (head.empty() || head[0] != '$' || head.substr(0, 4) == "$End")
        c_.fail("expected a section header such as $Nodes, got '" + printable(head) + "'");
      const std::string name(head.substr(1));
      c_.next_line();
      if (name == "MeshFormat") {
        c_.fail_at(header_line, "second $MeshFormat section");
      } else if (name == "PhysicalNames") {
        read_physical_names();
      } else if (name == "Entities" && major_ == 4) {
        read_entities();
      } else if (name == "PartitionedEntities" && major_ == 4) {
        read_partitioned_entities(header_line);
      } else if (name == "Nodes" || (name == "ParametricNodes" && major_ == 2)) {
        if (have_nodes_) c_.fail_at(header_line, "second $Nodes section");
        major_ == 4 ? read_nodes_v4() : read_nodes_v2(name == "ParametricNodes");
        finish_nodes();
      } else if (name == "Elements") {
        if (have_elements_) c_.fail_at(header_line, "second $Elements section");
        if (!have_nodes_) c_.fail_at(header_line, "$Elements before $Nodes");
        major_ == 4 ? read_elements_v4() : read_elements_v2();
        have_elements_ = true;
      } else {
        skip_section(name, header_line);
        continue;
      }
      expect_end(name);
    }
    if (!have_nodes_) c_.fail("missing $Nodes section");
    if (!have_elements_) c_.fail("missing $Elements section");
    check_volume_elements();
    check_partitions();
    assign_groups();
    mesh_.msh_major = major_;
    return std::move(mesh_);
  }

 private:
  // ---- framing -------------------------------------------------------------------------------
  void read_format() {
    const bool any = c_.skip_empty_lines();
    const std::string_view head = any ? c_.rest_of_line() : std::string_view();
    if (head == "$NOD")
      c_.fail("an MSH 1 file (it starts with " + std::string(head) + "): re-export it as MSH 2.2 or 4.1 ASCII, e.g. gmsh " +
              file_.filename().string() + " -save -format msh22 -o new.msh");
    // Lines ended by a carriage return alone read as one line: "$MeshFormat\r2.2 0 8\r...".
    if (head.rfind("$MeshFormat\r", 0) == 0)
      c_.fail("lines end in a carriage return alone (classic Mac line ends): convert them to line feeds (\\n)");
    if (head != "$MeshFormat") c_.fail("not a Gmsh MSH file: expected $MeshFormat");
    c_.next_line();
    c_.skip_empty_lines();
    std::string_view version = c_.token();
    if (version == "2" || version == "2.0" || version == "2.1" || version == "2.2") {
      major_ = 2;
    } else if (version == "4.1") {
      major_ = 4;
    } else {
      c_.fail("unsupported MSH version '" + printable(version) + "' (supported: 2.2 and 4.1 ASCII; re-export with Gmsh)");
    }
    const long long file_type = c_.integer("file type", 0, 1);
    if (file_type == 1)
      c_.fail("binary MSH files are not supported: re-export as ASCII (Gmsh option Mesh.Binary = 0)");
    c_.integer("data size", 1, 16);
    c_.end_line("");
    expect_end("MeshFormat");
  }

  void expect_end(const std::string& name) {
    const std::string end = "$End" + name;
    if (!c_.skip_empty_lines()) c_.fail("unexpected end of file: missing " + end);
    std::string_view got = c_.rest_of_line();
    if (got != end) c_.fail("expected " + end + ", got '" + printable(got) + "'");
    c_.next_line();
  }

  void skip_section(const std::string& name, long long header_line) {
    const std::string end = "$End" + name;
    while (c_.skip_empty_lines()) {
      if (c_.rest_of_line() == end) {
        c_.next_line();
        return;
      }
      c_.next_line();
    }
    c_.fail_at(header_line, "section $" + printable(name) + " has no " + printable(end));
  }

  /// Moves to the next non-empty line or fails naming what was being read.
  void need_line(const char* what, long long done, long long total) {
    if (!c_.skip_empty_lines())
      c_.fail("unexpected end of file: read " + std::to_string(done) + " of " + std::to_string(total) + " " + what);
  }

  /// Reads a record count and checks that the rest of the file could hold that many records of
  /// at least `min_bytes` bytes each, so no allocation is ever sized by an absurd count.
  long long count(const char* what, long long min_bytes) {
    const long long n = c_.integer(what, 0, INT_MAX);
    if (n > static_cast<long long>(c_.remaining() / static_cast<std::size_t>(min_bytes)))
      c_.fail(std::string(what) + " " + std::to_string(n) + " is larger than the rest of the file can hold");
    return n;
  }

  // ---- $PhysicalNames ---------------------------------------------------------------------------
  void read_physical_names() {
    c_.skip_empty_lines();
    const long long n = count("physical name count", 6);
    c_.end_line("");
    for (long long i = 0; i < n; ++i) {
      need_line("physical names", i, n);
      const int dim = static_cast<int>(c_.integer("physical group dimension", 0, 3));
      const int tag = static_cast<int>(c_.integer("physical tag", 0, INT_MAX - 1));
      std::string_view name = c_.rest_of_line();
      if (!name.empty() && name.front() == '"') {
        // Gmsh writes a name as it is between double quotes and reads it up to the next double
        // quote: it has no escapes (a backslash is a character of the name) and no name holds a
        // double quote. Text after that quote (`"a \"b\""`, `"a "b""`) is refused, not cut off as
        // Gmsh cuts it: the name meant is not the name Gmsh reads.
        const std::size_t close = name.find('"', 1);
        if (close == std::string_view::npos) c_.fail("unterminated quoted physical name");
        if (close + 1 != name.size()) {
          std::string_view rest = name.substr(close + 1);
          while (rest.front() == ' ' || rest.front() == '\t') rest.remove_prefix(1);  // (rest_of_line ends in a non-blank)
          c_.fail("text '" + printable(rest) + "' after the physical name \"" + printable(name.substr(1, close - 1)) +
                  "\": Gmsh reads a name from its double quote to the next, without escapes (no name holds a double "
                  "quote), and would drop the rest");
        }
        name = name.substr(1, close - 1);
      }
      if (name.empty()) c_.fail("empty physical name for tag " + std::to_string(tag));
      if (dim < 2) mesh_.point_curve_groups.emplace(std::string(name), dim);
      if (dim >= 2) {
        // A tag named twice in one dimension: the last would win silently (pins and messages by name).
        if (const auto it = names_[dim - 2].find(tag); it != names_[dim - 2].end() && it->second != name)
          c_.fail("physical tag " + std::to_string(tag) + " of dimension " + std::to_string(dim) + " is named twice, '" +
                  it->second + "' and '" + std::string(name) + "'");
        names_[dim - 2][tag] = std::string(name);
      }
      c_.next_line();
    }
  }

  // ---- $Entities (4.1) ------------------------------------------------------------------------
  /// The line of entity counts by dimension (points, curves, surfaces, volumes).
  std::array<long long, 4> entity_counts() {
    c_.skip_empty_lines();
    std::array<long long, 4> n{};
    for (int d = 0; d < 4; ++d) n[d] = count("entity count", 8);
    c_.end_line("");
    return n;
  }

  void read_entities() {
    const std::array<long long, 4> n = entity_counts();
    for (int d = 0; d < 4; ++d) {
      for (long long i = 0; i < n[d]; ++i) {
        need_line("entities", i, n[d]);
        const long long tag = c_.integer("entity tag", -kMaxTag, kMaxTag);
        const int coords = d == 0 ? 3 : 6;  // a point's position, or a bounding box
        for (int k = 0; k < coords; ++k) c_.real("entity coordinate");
        std::vector<int> physical = read_physical_tags();
        listed_entities_.insert({d, tag});
        if (!physical.empty() && d >= 2) entity_physical_[{d, tag}] = std::move(physical);
        c_.next_line();  // bounding entities follow: not needed
      }
    }
  }

  // ---- $PartitionedEntities (4.1, a partitioned mesh: gmsh -part N) --------------------------------
  /// The elements of a partitioned file lie on partitioned entities, each a piece of a parent
  /// entity ("tag parentDim parentTag numPartitions partitionTag ... coordinates numPhysicalTags
  /// physicalTag ... [numBoundingEntities ...]", the coordinates as in $Entities). A piece of the
  /// same dimension as its parent carries the parent's physical tags. A piece of a lower one is a
  /// boundary between partitions inside its parent: its tags are the parent's, not groups of its
  /// dimension, and its elements (triangles inside the volume) are not the mesh's: skipped. A ghost
  /// entity (gmsh -part_ghosts) holds copies of other partitions' tets next to a partition's:
  /// skipped too (a file split per partition holds them beside its own).
  void read_partitioned_entities(long long header_line) {
    c_.skip_empty_lines();
    partitions_line_ = header_line;
    partitions_ = c_.integer("partition count", 0, INT_MAX);
    c_.end_line("");
    c_.skip_empty_lines();
    const long long ghosts = count("ghost entity count", 4);
    c_.end_line("");
    for (long long i = 0; i < ghosts; ++i) {
      need_line("ghost entities", i, ghosts);
      ghost_entities_.insert(c_.integer("ghost entity tag", -kMaxTag, kMaxTag));
      c_.integer("partition", 0, kMaxTag);
      c_.end_line("");
    }
    const std::array<long long, 4> n = entity_counts();
    for (int d = 0; d < 4; ++d) {
      for (long long i = 0; i < n[d]; ++i) {
        need_line("partitioned entities", i, n[d]);
        const long long tag = c_.integer("entity tag", -kMaxTag, kMaxTag);
        const int parent_dim = static_cast<int>(c_.integer("parent dimension", 0, 3));
        c_.integer("parent tag", -kMaxTag, kMaxTag);
        const long long parts = c_.integer("partition count", 0, static_cast<long long>(c_.remaining()));
        for (long long k = 0; k < parts; ++k) {
          const long long part = c_.integer("partition tag", -kMaxTag, kMaxTag);
          if (d == 3 && parent_dim == 3) volume_partitions_.insert(part);
        }
        const int coords = d == 0 ? 3 : 6;
        for (int k = 0; k < coords; ++k) c_.real("entity coordinate");
        std::vector<int> physical = read_physical_tags();
        listed_entities_.insert({d, tag});
        if (parent_dim > d) partition_boundaries_.insert({d, tag});
        if (d >= 2 && parent_dim == d) {
          if (physical.empty()) {
            entity_physical_.erase({d, tag});
          } else {
            entity_physical_[{d, tag}] = std::move(physical);
          }
        }
        c_.next_line();  // bounding entities follow: not needed
      }
    }
  }

  /// Reads "numPhysicalTags physicalTag ..." of an entity: its groups, each once, in file order
  /// (a negative tag, which Gmsh writes for a group of reversed orientation, is the same group).
  std::vector<int> read_physical_tags() {
    const long long nphys = c_.integer("physical tag count", 0, static_cast<long long>(c_.remaining()));
    std::vector<int> tags;
    for (long long k = 0; k < nphys; ++k) {
      const long long p = c_.integer("physical tag", -(long long)INT_MAX, INT_MAX - 1);
      const int tag = static_cast<int>(p < 0 ? -p : p);
      if (tag != 0 && std::find(tags.begin(), tags.end(), tag) == tags.end()) tags.push_back(tag);
    }
    return tags;
  }

  // ---- $Nodes ---------------------------------------------------------------------------------
  void add_node(long long id, const Vec3d& p, long long line) {
    mesh_.vertices.push_back(p);
    mesh_.file_node_ids.push_back(id);
    node_lines_.push_back(line);
  }

  Vec3d read_xyz(long long id) {
    const std::string ctx = node_ctx(id);
    const double x = c_.real("x coordinate", ctx);
    const double y = c_.real("y coordinate", ctx);
    const double z = c_.real("z coordinate", ctx);
    return {x, y, z};
  }

  /// $Nodes, or $ParametricNodes (gmsh -parametric), whose lines go on after x y z with the node's
  /// entity (dimension, tag) and its parametric coordinates on it: not needed.
  void read_nodes_v2(bool parametric) {
    c_.skip_empty_lines();
    const long long n = count("node count", 8);  // "1 0 0 0\n"
    c_.end_line("");
    reserve_nodes(n);
    for (long long i = 0; i < n; ++i) {
      need_line("nodes", i, n);
      const long long line = c_.line();
      const long long id = c_.integer("node id", 1, kMaxTag);
      const Vec3d p = read_xyz(id);
      if (parametric) {
        c_.integer("entity dimension", 0, 3, node_ctx(id));
        c_.next_line();
      } else {
        c_.end_line(node_ctx(id));
      }
      add_node(id, p, line);
    }
  }

  void read_nodes_v4() {
    c_.skip_empty_lines();
    const long long blocks = count("node block count", 8);
    const long long n = count("node count", 8);  // a tag line and a coordinate line per node
    c_.integer("minimum node tag", 0, kMaxTag);
    c_.integer("maximum node tag", 0, kMaxTag);
    c_.end_line("");
    reserve_nodes(n);
    long long done = 0;
    std::vector<long long> ids;
    std::vector<long long> lines;
    for (long long b = 0; b < blocks; ++b) {
      need_line("node blocks", b, blocks);
      c_.integer("entity dimension", 0, 3);
      c_.integer("entity tag", -kMaxTag, kMaxTag);
      const bool parametric = c_.integer("parametric flag", 0, 1) == 1;
      const long long m = c_.integer("nodes in block", 0, n - done);
      c_.end_line("");
      ids.clear();
      lines.clear();
      for (long long i = 0; i < m; ++i) {
        need_line("node tags of a block", i, m);
        lines.push_back(c_.line());
        ids.push_back(c_.integer("node id", 1, kMaxTag));
        c_.end_line(node_ctx(ids.back()));
      }
      for (long long i = 0; i < m; ++i) {
        need_line("node coordinates of a block", i, m);
        const Vec3d p = read_xyz(ids[i]);
        if (parametric) {
          c_.next_line();  // parametric coordinates follow: not needed
        } else {
          c_.end_line(node_ctx(ids[i]));
        }
        add_node(ids[i], p, lines[i]);
      }
      done += m;
    }
    if (done != n) c_.fail("node blocks hold " + std::to_string(done) + " nodes, the header says " + std::to_string(n));
  }

  void reserve_nodes(long long n) {
    mesh_.vertices.reserve(static_cast<std::size_t>(n));
    mesh_.file_node_ids.reserve(static_cast<std::size_t>(n));
    node_lines_.reserve(static_cast<std::size_t>(n));
  }

  /// Builds the node id -> vertex index map; rejects duplicate ids.
  void finish_nodes() {
    have_nodes_ = true;
    const auto& ids = mesh_.file_node_ids;
    const std::size_t n = ids.size();
    long long max_id = 0;
    for (long long id : ids) max_id = std::max(max_id, id);
    if (max_id <= 4 * static_cast<long long>(n) + 1024) {
      dense_.assign(static_cast<std::size_t>(max_id) + 1, -1);
      for (std::size_t i = 0; i < n; ++i) {
        int& slot = dense_[static_cast<std::size_t>(ids[i])];
        if (slot >= 0) c_.fail_at(node_lines_[i], "duplicate node id " + std::to_string(ids[i]) + node_ctx(ids[i]));
        slot = static_cast<int>(i);
      }
    } else {
      sparse_.resize(n);
      for (std::size_t i = 0; i < n; ++i) sparse_[i] = {ids[i], static_cast<int>(i)};
      std::sort(sparse_.begin(), sparse_.end());
      for (std::size_t i = 1; i < n; ++i) {
        if (sparse_[i].first == sparse_[i - 1].first) {
          const auto later = std::max(sparse_[i].second, sparse_[i - 1].second);
          c_.fail_at(node_lines_[static_cast<std::size_t>(later)],
                     "duplicate node id " + std::to_string(sparse_[i].first) + node_ctx(sparse_[i].first));
        }
      }
    }
    node_lines_.clear();
    node_lines_.shrink_to_fit();
  }

  int vertex_of(long long node_id, long long element_id) {
    if (!dense_.empty()) {
      if (node_id >= 0 && node_id < static_cast<long long>(dense_.size()) && dense_[static_cast<std::size_t>(node_id)] >= 0)
        return dense_[static_cast<std::size_t>(node_id)];
    } else {
      auto it = std::lower_bound(sparse_.begin(), sparse_.end(), std::pair<long long, int>{node_id, INT_MIN});
      if (it != sparse_.end() && it->first == node_id) return it->second;
    }
    c_.fail("unknown node id " + std::to_string(node_id) + element_ctx(element_id));
  }

  // ---- $Elements ------------------------------------------------------------------------------
  /// The element type `type` (a token just read), refused where Gmsh has no such type.
  const ElementType& known_type(long long type, const std::string& ctx) {
    const ElementType* t = element_type(static_cast<int>(type));
    if (!t) c_.fail("unknown element type " + std::to_string(type) + ctx);
    return *t;
  }

  /// Reads an element's node list (the cursor is just before it, `line` the element's line), each
  /// node checked to be the file's. A tet or a triangle is stored with its physical groups
  /// (`physical`: none, or the first and then any others) where `own` (not a 4.1 partition
  /// boundary's or ghost entity's); another volume element is noted for check_volume_elements,
  /// which refuses the file (its line read past); points, lines and the other surface elements
  /// are left out.
  void read_element(const ElementType& type, long long id, long long line, const std::vector<int>& physical, bool own) {
    if (other_volume(type)) {
      if (own) note_other_volume_element(type.type, line);
      c_.next_line();
      return;
    }
    const std::string ctx = element_ctx(id);
    // A polygon's node count comes first in MSH 2 (Gmsh's MElement::writeMSH2); 4.1 has none.
    const long long nodes = type.nodes > 0 || major_ == 4 ? type.nodes : c_.integer("node count", 0, INT_MAX, ctx);
    int v[4] = {0, 0, 0, 0};
    for (long long k = 0; k < nodes; ++k) {
      const int vertex = vertex_of(c_.integer("node id", 1, kMaxTag, ctx), id);
      if (k < 4) v[k] = vertex;
    }
    c_.end_line(ctx);
    const int first = physical.empty() ? 0 : physical[0];
    if (own && type.type == kTypeTet) {
      for (std::size_t k = 1; k < physical.size(); ++k)
        mesh_.tet_more_groups.push_back({static_cast<int>(mesh_.tets.size()), physical[k]});
      mesh_.tets.push_back({v[0], v[1], v[2], v[3]});
      mesh_.tet_group.push_back(first);
      mesh_.file_tet_ids.push_back(id);
    } else if (own && type.type == kTypeTriangle) {
      for (std::size_t k = 1; k < physical.size(); ++k)
        mesh_.triangle_more_groups.push_back({static_cast<int>(mesh_.triangles.size()), physical[k]});
      mesh_.triangles.push_back({v[0], v[1], v[2]});
      mesh_.triangle_group.push_back(first);
    }
  }

  /// MSH 2 writes an element in several physical groups once per group (the same type and nodes,
  /// each copy with one group): merges the copies into the first, which gets the union of their
  /// groups (tet_more_groups / triangle_more_groups), and keeps the elements' file order.
  /// `copies_only`: a repeat in a group an earlier copy has, or without a group where no copy has
  /// one, is not such a copy but the element listed twice (two files joined, an entity meshed
  /// twice): it stays, for the mesh check to refuse as in a 4.1 file.
  template <class Element>
  static void merge_repeated(std::vector<Element>& elements, std::vector<int>& group,
                             std::vector<std::pair<int, int>>& more, std::vector<long long>* file_ids,
                             bool copies_only) {
    const std::size_t n = elements.size();
    std::vector<int> order(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = static_cast<int>(i);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return elements[a] < elements[b]; });
    std::vector<int> into(n, -1);  // a repeated element -> the first copy
    for (std::size_t i = 1; i < n; ++i)
      if (elements[order[i]] == elements[order[i - 1]]) into[order[i]] = into[order[i - 1]] >= 0 ? into[order[i - 1]] : order[i - 1];
    // each first copy's groups: its own, then the copies' in file order (0, no group, only alone)
    std::map<int, std::vector<int>> groups;
    for (std::size_t i = 0; i < n; ++i) {
      if (into[i] < 0) continue;
      std::vector<int>& g = groups[into[i]];
      if (g.empty()) g.push_back(group[into[i]]);
      const bool seen = std::find(g.begin(), g.end(), group[i]) != g.end();
      if (copies_only && seen && (group[i] != 0 || std::all_of(g.begin(), g.end(), [](int t) { return t == 0; }))) {
        into[i] = -1;  // listed twice, not a copy for a group
        continue;
      }
      g.push_back(group[i]);
    }
    if (std::all_of(into.begin(), into.end(), [](int f) { return f < 0; })) return;
    std::vector<int> index(n, -1);
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (into[i] >= 0) continue;
      index[i] = static_cast<int>(kept);
      elements[kept] = elements[i];
      group[kept] = group[i];
      if (file_ids) (*file_ids)[kept] = (*file_ids)[i];
      ++kept;
    }
    elements.resize(kept);
    group.resize(kept);
    if (file_ids) file_ids->resize(kept);
    for (auto& [e, tag] : more) e = index[e];  // (MSH 2 has none before the merge)
    for (auto& [first, tags] : groups) {
      std::vector<int> unique;
      for (int t : tags)
        if (t != 0 && std::find(unique.begin(), unique.end(), t) == unique.end()) unique.push_back(t);
      if (unique.empty()) continue;
      const int e = index[first];
      group[e] = unique[0];
      for (std::size_t k = 1; k < unique.size(); ++k) more.push_back({e, unique[k]});
    }
    std::sort(more.begin(), more.end());
  }

  void read_elements_v2() {
    c_.skip_empty_lines();
    const long long n = count("element count", 8);  // "1 15 0 1\n"
    c_.end_line("");
    for (long long i = 0; i < n; ++i) {
      need_line("elements", i, n);
      const long long line = c_.line();
      const long long id = c_.integer("element id", 1, kMaxTag);
      const std::string ctx = element_ctx(id);
      const ElementType& type = known_type(c_.integer("element type", 1, 1 << 20, ctx), ctx);
      const long long ntags = c_.integer("tag count", 0, 64, ctx);
      long long physical = 0;
      for (long long k = 0; k < ntags; ++k) {
        const long long t = c_.integer("element tag", -kMaxTag, kMaxTag, ctx);
        if (k == 0) physical = t;
      }
      if (physical < 0 || physical > INT_MAX - 1) c_.fail("physical tag " + std::to_string(physical) + " is out of range" + ctx);
      read_element(type, id, line, physical == 0 ? std::vector<int>{} : std::vector<int>{static_cast<int>(physical)}, true);
    }
    // A tet listed twice is refused by the mesh check; a triangle only labels a surface group.
    merge_repeated(mesh_.tets, mesh_.tet_group, mesh_.tet_more_groups, &mesh_.file_tet_ids, true);
    merge_repeated(mesh_.triangles, mesh_.triangle_group, mesh_.triangle_more_groups, nullptr, false);
  }

  void read_elements_v4() {
    c_.skip_empty_lines();
    const long long blocks = count("element block count", 8);
    const long long n = count("element count", 4);  // "1 1\n"
    c_.integer("minimum element tag", 0, kMaxTag);
    c_.integer("maximum element tag", 0, kMaxTag);
    c_.end_line("");
    long long done = 0;
    for (long long b = 0; b < blocks; ++b) {
      need_line("element blocks", b, blocks);
      const int dim = static_cast<int>(c_.integer("entity dimension", 0, 3));
      const long long entity = c_.integer("entity tag", -kMaxTag, kMaxTag);
      // A block on an entity the file's entities do not list (meshio writes its surfaces so):
      // its elements' physical groups are unknown. Read without groups and counted, for the
      // messages of a pin by group that then finds none of them.
      const bool ghost = dim == 3 && ghost_entities_.count(entity);
      const bool off_entities = !listed_entities_.empty() && dim >= 2 && !ghost && !listed_entities_.count({dim, entity});
      const long long block_line = c_.line();
      const ElementType& type = known_type(c_.integer("element type", 1, 1 << 20), "");
      if (type.shape.dim != dim)
        c_.fail("a block of entity dimension " + std::to_string(dim) + " holds " + type_name(type, true) + " (type " +
                std::to_string(type.type) + "), elements of dimension " + std::to_string(type.shape.dim));
      const long long m = c_.integer("elements in block", 0, n - done);
      c_.end_line("");
      if (off_entities && (type.type == kTypeTet || type.type == kTypeTriangle) && m > 0) {
        if (mesh_.elements_off_entities == 0) mesh_.first_off_entities_line = block_line;
        mesh_.elements_off_entities += m;
      }
      static const std::vector<int> kNone;
      auto it = entity_physical_.find({dim, entity});
      const std::vector<int>& physical = it != entity_physical_.end() ? it->second : kNone;
      const bool own = !partition_boundaries_.count({dim, entity}) && !ghost;
      for (long long i = 0; i < m; ++i) {
        need_line("elements of a block", i, m);
        const long long line = c_.line();
        read_element(type, c_.integer("element id", 1, kMaxTag), line, physical, own);
      }
      done += m;
    }
    if (done != n) c_.fail("element blocks hold " + std::to_string(done) + " elements, the header says " + std::to_string(n));
  }

  // ---- volume element types -------------------------------------------------------------------
  /// Notes a volume element that is not a 4-node tet (`line`: where it is).
  void note_other_volume_element(int type, long long line) {
    if (other_volume_.empty()) first_other_volume_line_ = line;
    ++other_volume_[type];
  }

  /// Refuses a mesh whose volume is not all 4-node tets: the others would be dropped, leaving a
  /// cut-down organ. Names each kind with its count and the line of the first such element.
  void check_volume_elements() {
    const bool only_tet10 = other_volume_.size() == 1 && other_volume_.begin()->first == kTypeTet10;
    if (mesh_.tets.empty() && (other_volume_.empty() || only_tet10)) {
      std::string what = "no 4-node tetrahedra (element type 4) in the file";
      if (only_tet10) {
        what += "; it has " + std::to_string(other_volume_.begin()->second) +
                " 10-node tetrahedra (type 11): re-mesh with Mesh.ElementOrder = 1";
      } else if (!names_[0].empty() || !names_[1].empty() ||
                 std::any_of(mesh_.triangle_group.begin(), mesh_.triangle_group.end(), [](int g) { return g != 0; })) {
        what += " (gmsh saves only the elements in physical groups when there are any: add a Physical Volume, or save with -save_all)";
      } else if (!mesh_.triangles.empty()) {
        what += " (it holds a surface mesh only: mesh the volume, e.g. gmsh -3)";
      }
      c_.fail(what);
    }
    if (other_volume_.empty()) return;
    std::string kinds;
    bool high_order = false;
    std::size_t i = 0;
    for (const auto& [type, n] : other_volume_) {
      const ElementType& t = *element_type(type);
      high_order = high_order || t.nodes != t.shape.nodes;
      kinds += i == 0 ? "" : (i + 1 == other_volume_.size() ? " and " : ", ");
      kinds += std::to_string(n) + " " + type_name(t, n != 1) + " (type " + std::to_string(type) + ")";
      ++i;
    }
    const std::string hint = std::string(": ebh needs an all-tet mesh (mesh with 4-node tets only, e.g. gmsh -3 without Recombine") +
                             (high_order ? " and with Mesh.ElementOrder = 1)" : ")");
    if (mesh_.tets.empty())
      c_.fail_at(first_other_volume_line_, "no 4-node tetrahedra (element type 4) in the file; it has " + kinds + hint);
    c_.fail_at(first_other_volume_line_, kinds + " besides the tets" + hint);
  }

  /// Refuses a file that holds only some partitions of a partitioned mesh (Gmsh writes one file per
  /// partition with -part_split, Mesh.PartitionSplitMeshFiles = 1): read alone it would be taken
  /// for the whole organ.
  void check_partitions() {
    if (partitions_ <= 1 || volume_partitions_.empty() || static_cast<long long>(volume_partitions_.size()) >= partitions_)
      return;
    std::string held;
    for (long long p : volume_partitions_) held += (held.empty() ? "" : ", ") + std::to_string(p);
    c_.fail_at(partitions_line_, "the file holds the tets of partition" + std::string(volume_partitions_.size() == 1 ? " " : "s ") +
                                     held + " of " + std::to_string(partitions_) +
                                     " only (Gmsh wrote one file per partition: -part_split, Mesh.PartitionSplitMeshFiles); "
                                     "save the mesh as one file (without -part_split) or unpartitioned");
  }

  // ---- groups ---------------------------------------------------------------------------------
  /// Fills group_names; gives a surface group a fresh tag where its tag clashes with a
  /// differently named volume group. An unnamed surface group so moved is named by its number in
  /// the file, which a scene's pin uses for an unnamed group.
  void assign_groups() {
    std::set<int> tags3(mesh_.tet_group.begin(), mesh_.tet_group.end());
    std::set<int> tags2(mesh_.triangle_group.begin(), mesh_.triangle_group.end());
    for (const auto& [t, tag] : mesh_.tet_more_groups) tags3.insert(tag);
    for (const auto& [f, tag] : mesh_.triangle_more_groups) tags2.insert(tag);
    for (const auto& [tag, name] : names_[1]) tags3.insert(tag);
    for (const auto& [tag, name] : names_[0]) tags2.insert(tag);
    int next = 0;
    for (int t : tags3) next = std::max(next, t);
    for (int t : tags2) next = std::max(next, t);
    auto name_of = [](const std::map<int, std::string>& m, int tag) {
      auto it = m.find(tag);
      return it == m.end() ? std::string() : it->second;
    };
    std::map<int, int> remap;
    for (int t : tags2)
      if (t != 0 && tags3.count(t) && name_of(names_[0], t) != name_of(names_[1], t)) remap[t] = ++next;
    for (int& g : mesh_.triangle_group)
      if (auto it = remap.find(g); it != remap.end()) g = it->second;
    for (auto& [f, g] : mesh_.triangle_more_groups)
      if (auto it = remap.find(g); it != remap.end()) g = it->second;
    std::sort(mesh_.triangle_more_groups.begin(), mesh_.triangle_more_groups.end());
    for (const auto& [tag, name] : names_[1]) mesh_.group_names[tag] = name;
    for (const auto& [tag, name] : names_[0]) {
      auto it = remap.find(tag);
      mesh_.group_names[it == remap.end() ? tag : it->second] = name;
    }
    for (const auto& [from, to] : remap) {
      if (!names_[0].count(from)) mesh_.group_names[to] = std::to_string(from);
      mesh_.group_file_tags[to] = from;
    }
  }

  TextCursor c_;
  std::filesystem::path file_;
  int major_ = 0;
  bool have_nodes_ = false;
  bool have_elements_ = false;
  TetMesh mesh_;
  std::vector<long long> node_lines_;              ///< #V line of each node (until the map is built)
  std::vector<int> dense_;                         ///< node id -> vertex, when ids are compact
  std::vector<std::pair<long long, int>> sparse_;  ///< sorted (node id, vertex), otherwise
  std::map<std::pair<int, long long>, std::vector<int>> entity_physical_;  ///< (dim, entity tag) -> its groups
  std::set<std::pair<int, long long>> listed_entities_;  ///< (dim, entity tag) of $Entities and $PartitionedEntities
  std::set<std::pair<int, long long>> partition_boundaries_;  ///< (dim, tag) of partitioned entities between partitions
  std::set<long long> ghost_entities_;             ///< tags of ghost entities (other partitions' tets)
  std::set<long long> volume_partitions_;          ///< the partitions of the file's volume pieces
  long long partitions_ = 0;                       ///< $PartitionedEntities' partition count (0: none)
  long long partitions_line_ = 0;                  ///< its section's line
  std::map<int, std::string> names_[2];            ///< physical names of dimension 2 and 3
  std::map<int, long long> other_volume_;          ///< element type -> count, volume types but type 4
  long long first_other_volume_line_ = 0;
};

}  // namespace

TetMesh read_msh(const std::filesystem::path& file) {
  const std::string text = detail::read_file_bytes(file);
  return MshParser(file, text).parse();
}

}  // namespace ebh
