// VTK XML reader for the physical mesh (.vtu): an UnstructuredGrid whose arrays are ascii, binary
// (base64 inline) or appended (raw or base64), uncompressed or zlib-compressed, as VTK, ParaView,
// 3D Slicer and meshio write it. Format reference: "VTK File Formats", the VTK User's Guide,
// "XML File Formats" (the arrays' headers and compressed blocks as vtkXMLDataParser reads them).
#include <zlib.h>

#include <algorithm>
#include <charconv>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "core/error.hpp"
#include "mesh/binary_values.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/polygon.hpp"
#include "mesh/text_cursor.hpp"
#include "mesh/vtk_names.hpp"

namespace ebh {
namespace {

using detail::printable;

/// An XML element's start tag: its name, attributes and where it is.
struct Tag {
  std::string name;
  std::map<std::string, std::string> attrs;
  bool empty = false;          ///< <name ... />
  bool closing = false;        ///< </name>
  std::size_t end = 0;         ///< the byte after '>'
  long long line = 0;
  const std::string* attr(const std::string& key) const {
    auto it = attrs.find(key);
    return it == attrs.end() ? nullptr : &it->second;
  }
};

/// A DataArray: its attributes and, for ascii and binary ones, its text.
struct ArrayRef {
  std::string name, type, format;
  long long components = 1;
  std::optional<long long> offset;  ///< appended: the offset after '_'
  std::string_view text;            ///< ascii, binary: the element's text
  long long line = 0;
  /// The array as messages name it.
  std::string what() const { return "DataArray " + printable(name.empty() ? type : name); }
};

/// A number type of the format: its size, and whether it is a real or a signed integer.
struct NumberType {
  int bytes = 0;
  bool real = false, is_signed = true;
};

class VtuParser {
 public:
  VtuParser(const std::filesystem::path& file, std::string bytes) : file_(file), bytes_(std::move(bytes)) {}

  TetMesh parse() {
    const std::vector<Piece> pieces = scan();
    several_pieces_ = pieces.size() > 1;
    for (const Piece& p : pieces) read_piece(p);
    if (mesh_.tets.empty()) fail(pieces.front().line, "no tetrahedra (cell type 10) among the cells");
    mesh_.file_node_ids.resize(mesh_.vertices.size());
    for (std::size_t i = 0; i < mesh_.vertices.size(); ++i) mesh_.file_node_ids[i] = static_cast<long long>(i);
    return std::move(mesh_);
  }

  /// A PolyData's (.vtp) surface: its Polys (split around their first corner, convex ones only) and
  /// Strips (in alternating order) as triangles, over its pieces; Verts and Lines not read.
  SurfaceMesh parse_surface() {
    surface_ = true;
    const std::vector<Piece> pieces = scan();
    several_pieces_ = pieces.size() > 1;
    SurfaceMesh out;
    for (const Piece& p : pieces) {
      const long long base = read_points(p);
      polygons(p, p.polys, "Polys", base, out);
      polygons(p, p.strips, "Strips", base, out);
    }
    if (out.triangles.empty()) fail(pieces.front().line, "no Polys or Strips: a surface is a list of polygons");
    out.vertices = std::move(mesh_.vertices);
    return out;
  }

 private:
  /// A PolyData's Polys or Strips: how many, and their two arrays.
  struct CellSection {
    long long count = 0;
    std::optional<ArrayRef> connectivity, offsets;
  };
  struct Piece {
    long long points = 0, cells = 0, line = 0;
    std::optional<ArrayRef> xyz, connectivity, offsets, types, groups;
    CellSection polys, strips;  ///< a PolyData's
  };

  /// The pieces and where their arrays are, up to </VTKFile> or the appended data.
  std::vector<Piece> scan() {
    header();
    std::vector<Piece> pieces;
    Piece* piece = nullptr;
    std::string section;  // Points, Cells, CellData, PointData, ...
    while (true) {
      const std::optional<Tag> t = next_tag();
      if (!t) fail(line_at(pos_), "the file ends before </VTKFile> (cut short?)");
      if (t->closing) {
        if (t->name == "VTKFile") break;
        if (t->name == "Piece") piece = nullptr;
        if (t->name == section) section.clear();
        continue;
      }
      if (t->name == "AppendedData") {
        appended(*t);
        break;  // raw bytes follow: nothing after them is read
      }
      if (t->name == "UnstructuredGrid" || t->name == "FieldData") {
        continue;
      }
      if (t->name == "Piece") {
        pieces.emplace_back();
        piece = &pieces.back();
        piece->line = t->line;
        piece->points = whole_attr(*t, "NumberOfPoints");
        if (!surface_) piece->cells = whole_attr(*t, "NumberOfCells");
        if (surface_ && t->attr("NumberOfPolys")) piece->polys.count = whole_attr(*t, "NumberOfPolys");
        if (surface_ && t->attr("NumberOfStrips")) piece->strips.count = whole_attr(*t, "NumberOfStrips");
        continue;
      }
      if (t->name == "Points" || t->name == "Cells" || t->name == "CellData" || t->name == "PointData" ||
          t->name == "Polys" || t->name == "Strips" || t->name == "Verts" || t->name == "Lines") {
        if (!piece) fail(t->line, "<" + t->name + "> outside a <Piece>");
        if (!t->empty) section = t->name;
        continue;
      }
      if (t->name == "DataArray") {
        ArrayRef a = array(*t);
        if (!t->empty) {
          // The values are the text before the first child element (VTK writes an InformationKey
          // after them, e.g. the points' L2_NORM_RANGE).
          const std::size_t close = bytes_.find("</DataArray>", t->end);
          if (close == std::string::npos) fail(t->line, "a <DataArray> without </DataArray>");
          a.text = std::string_view(bytes_).substr(t->end, bytes_.find('<', t->end) - t->end);
          pos_ = close + std::strlen("</DataArray>");
        }
        std::optional<ArrayRef>* slot = nullptr;  // where the mesh keeps it, if it does
        if (piece && section == "Points" && !piece->xyz) slot = &piece->xyz;
        else if (piece && section == "Cells" && a.name == "connectivity") slot = &piece->connectivity;
        else if (piece && section == "Cells" && a.name == "offsets") slot = &piece->offsets;
        else if (piece && section == "Cells" && a.name == "types") slot = &piece->types;
        else if (piece && (section == "Polys" || section == "Strips") && (a.name == "connectivity" || a.name == "offsets")) {
          CellSection& cells = section == "Polys" ? piece->polys : piece->strips;
          slot = a.name == "connectivity" ? &cells.connectivity : &cells.offsets;
        }
        else if (piece && section == "CellData" && !piece->groups && a.components == 1 && detail::is_vtk_group_array(a.name))
          slot = &piece->groups;
        if (slot) *slot = a;
        continue;
      }
      // Other elements (InformationKey, Array of FieldData, ...) carry nothing the mesh needs.
    }
    if (pieces.empty()) fail(1, std::string("no <Piece> in the <") + (surface_ ? "PolyData" : "UnstructuredGrid") + ">");
    return pieces;
  }

  [[noreturn]] void fail(long long line, const std::string& what) const {
    throw InputError(file_.string() + ":" + std::to_string(line) + ": " + what);
  }
  /// The line of byte `pos`, counted on from the last one asked for (the tags come in order).
  long long line_at(std::size_t pos) {
    pos = std::min(pos, bytes_.size());
    if (pos < counted_to_) {
      counted_to_ = 0;
      counted_lines_ = 1;
    }
    counted_lines_ += std::count(bytes_.begin() + static_cast<std::ptrdiff_t>(counted_to_),
                                 bytes_.begin() + static_cast<std::ptrdiff_t>(pos), '\n');
    counted_to_ = pos;
    return counted_lines_;
  }

  void header() {
    std::optional<Tag> t = next_tag();
    if (!t || t->name != "VTKFile")
      fail(t ? t->line : 1, "not a VTK XML file (no <VTKFile> element): a physical mesh is a Gmsh .msh, VTK .vtk or "
                            ".vtu, Medit .mesh or TetGen .node/.ele file");
    const std::string* type = t->attr("type");
    if (surface_ && (!type || *type != "PolyData"))
      fail(t->line, "a VTKFile of type '" + printable(type ? *type : "") + "' is no surface: the virtual mesh is a PolyData" +
                        (type && *type == "UnstructuredGrid" ? " (this file can be the physical mesh)" : ""));
    if (!surface_ && (!type || *type != "UnstructuredGrid"))
      fail(t->line, "a VTKFile of type '" + printable(type ? *type : "") +
                        (type && *type == "PUnstructuredGrid"
                             ? "' (a parallel file that names its pieces: merge them, e.g. ParaView's Merge Blocks, and "
                               "save one .vtu)"
                         : type && *type == "PolyData"
                             ? "' holds no tetrahedra (a surface: it can be the virtual mesh): the physical mesh is an "
                               "UnstructuredGrid of tets"
                             : "' holds no tetrahedra (the physical mesh is an UnstructuredGrid of tets)"));
    const std::string* order = t->attr("byte_order");
    big_endian_ = order && *order == "BigEndian";
    if (order && *order != "BigEndian" && *order != "LittleEndian")
      fail(t->line, "byte_order '" + printable(*order) + "' (LittleEndian or BigEndian)");
    header_bytes_ = 4;
    if (const std::string* h = t->attr("header_type")) {
      if (*h == "UInt64") header_bytes_ = 8;
      else if (*h != "UInt32") fail(t->line, "header_type '" + printable(*h) + "' (UInt32 or UInt64)");
    }
    if (const std::string* c = t->attr("compressor")) {
      if (*c == "vtkZLibDataCompressor") zlib_ = true;
      else if (!c->empty())
        fail(t->line, "compressor '" + printable(*c) + "' is not read: save the mesh uncompressed or with zlib "
                      "(ParaView: Compressor Type None or ZLib; meshio: compression=\"zlib\")");
    }
  }

  /// The next element's tag from pos_ (comments, declarations and text skipped); none at the end.
  std::optional<Tag> next_tag() {
    while (true) {
      const std::size_t lt = bytes_.find('<', pos_);
      if (lt == std::string::npos) return std::nullopt;
      if (bytes_.compare(lt, 4, "<!--") == 0) {
        const std::size_t e = bytes_.find("-->", lt);
        if (e == std::string::npos) fail(line_at(lt), "a comment without its end '-->'");
        pos_ = e + 3;
        continue;
      }
      if (bytes_.compare(lt, 2, "<?") == 0 || bytes_.compare(lt, 2, "<!") == 0) {
        const std::size_t e = bytes_.find('>', lt);
        if (e == std::string::npos) fail(line_at(lt), "a declaration without its end '>'");
        pos_ = e + 1;
        continue;
      }
      return tag_at(lt);
    }
  }

  static bool name_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '-' || c == '.'; }
  static bool space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

  Tag tag_at(std::size_t lt) {
    Tag t;
    t.line = line_at(lt);
    std::size_t p = lt + 1;
    if (p < bytes_.size() && bytes_[p] == '/') {
      t.closing = true;
      ++p;
    }
    const std::size_t n0 = p;
    while (p < bytes_.size() && name_char(bytes_[p])) ++p;
    t.name = bytes_.substr(n0, p - n0);
    if (t.name.empty()) fail(t.line, "a '<' that starts no element");
    while (true) {
      while (p < bytes_.size() && space(bytes_[p])) ++p;
      if (p >= bytes_.size()) fail(t.line, "<" + printable(t.name) + ": the file ends inside the tag");
      if (bytes_[p] == '>') break;
      if (bytes_.compare(p, 2, "/>") == 0) {
        t.empty = true;
        ++p;
        break;
      }
      const std::size_t k0 = p;
      while (p < bytes_.size() && name_char(bytes_[p])) ++p;
      const std::string key = bytes_.substr(k0, p - k0);
      while (p < bytes_.size() && space(bytes_[p])) ++p;
      if (key.empty() || p >= bytes_.size() || bytes_[p] != '=')
        fail(t.line, "<" + printable(t.name) + ">: a malformed attribute" + (key.empty() ? "" : " '" + printable(key) + "'"));
      ++p;
      while (p < bytes_.size() && space(bytes_[p])) ++p;
      if (p >= bytes_.size() || (bytes_[p] != '"' && bytes_[p] != '\''))
        fail(t.line, "<" + printable(t.name) + ">: attribute " + printable(key) + " has no quoted value");
      const char q = bytes_[p];
      const std::size_t e = bytes_.find(q, p + 1);
      if (e == std::string::npos) fail(t.line, "<" + printable(t.name) + ">: attribute " + printable(key) + "'s value has no end");
      t.attrs[key] = unescape(bytes_.substr(p + 1, e - p - 1));
      p = e + 1;
    }
    t.end = p + 1;
    pos_ = t.end;
    return t;
  }

  /// An attribute's value with XML's five entities replaced.
  static std::string unescape(const std::string& s) {
    static constexpr std::pair<std::string_view, char> kEntities[] = {
        {"&lt;", '<'}, {"&gt;", '>'}, {"&amp;", '&'}, {"&quot;", '"'}, {"&apos;", '\''}};
    std::string out;
    for (std::size_t i = 0; i < s.size(); ++i) {
      const auto* e = std::find_if(std::begin(kEntities), std::end(kEntities),
                                   [&](const auto& x) { return std::string_view(s).substr(i).starts_with(x.first); });
      if (e == std::end(kEntities)) {
        out += s[i];
        continue;
      }
      out += e->second;
      i += e->first.size() - 1;
    }
    return out;
  }

  /// A whole-number attribute in [0, hi].
  long long whole_attr(const Tag& t, const char* key, long long hi = INT32_MAX - 1) {
    const std::string* v = t.attr(key);
    if (!v) fail(t.line, "<" + t.name + "> has no " + key);
    long long out = 0;
    const auto [p, ec] = std::from_chars(v->data(), v->data() + v->size(), out);
    if (ec != std::errc() || p != v->data() + v->size() || out < 0 || out > hi)
      fail(t.line, "<" + t.name + "> " + key + " '" + printable(*v) + "' is not a whole number in [0, " + std::to_string(hi) + "]");
    return out;
  }

  ArrayRef array(const Tag& t) {
    ArrayRef a;
    a.line = t.line;
    if (const std::string* v = t.attr("Name")) a.name = *v;
    const std::string* type = t.attr("type");
    if (!type) fail(t.line, "a <DataArray> without a type");
    a.type = *type;
    const std::string* format = t.attr("format");
    a.format = format ? *format : "ascii";
    if (a.format != "ascii" && a.format != "binary" && a.format != "appended")
      fail(t.line, "DataArray " + printable(a.name) + ": format '" + printable(a.format) + "' (ascii, binary or appended)");
    if (t.attr("NumberOfComponents")) a.components = whole_attr(t, "NumberOfComponents", 1 << 20);
    if (a.components < 1) fail(t.line, "DataArray " + printable(a.name) + ": NumberOfComponents 0");
    if (a.format == "appended") a.offset = whole_attr(t, "offset", LLONG_MAX / 2);
    return a;
  }

  void appended(const Tag& t) {
    const std::string* enc = t.attr("encoding");
    appended_base64_ = enc && *enc == "base64";
    if (enc && *enc != "base64" && *enc != "raw") fail(t.line, "AppendedData encoding '" + printable(*enc) + "' (raw or base64)");
    const std::size_t u = bytes_.find('_', t.end);
    if (u == std::string::npos) fail(t.line, "AppendedData without its '_' before the data");
    appended_at_ = u + 1;
    appended_line_ = t.line;
  }

  static NumberType number_type(const std::string& type) {
    if (type == "Float32") return {4, true};
    if (type == "Float64") return {8, true};
    if (type == "Int8") return {1};
    if (type == "UInt8") return {1, false, false};
    if (type == "Int16") return {2};
    if (type == "UInt16") return {2, false, false};
    if (type == "Int32") return {4};
    if (type == "UInt32") return {4, false, false};
    if (type == "Int64") return {8};
    if (type == "UInt64") return {8, false, false};
    return {};
  }

  /// base64 decoded quantum by quantum: a stream of several encoded parts (VTK encodes a header and
  /// its data apart, each padded) decodes as their bytes in turn. Stops after `want` bytes where
  /// given; `used` gets the characters read.
  std::string base64(std::string_view s, long long line, const std::string& what, std::size_t want = SIZE_MAX,
                     std::size_t* used = nullptr) const {
    auto value = [](char c) -> int {
      if (c >= 'A' && c <= 'Z') return c - 'A';
      if (c >= 'a' && c <= 'z') return c - 'a' + 26;
      if (c >= '0' && c <= '9') return c - '0' + 52;
      if (c == '+') return 62;
      if (c == '/') return 63;
      return -1;
    };
    std::string out;
    std::size_t i = 0;
    int q[4];
    while (out.size() < want) {
      int n = 0, pad = 0;
      while (n < 4 && i < s.size()) {
        const char c = s[i++];
        if (space(c)) continue;
        if (c == '=') {
          q[n++] = 0;
          ++pad;
          continue;
        }
        const int v = value(c);
        if (v < 0 || pad > 0) fail(line, what + ": '" + printable(std::string(1, c)) + "' in base64 data");
        q[n++] = v;
      }
      if (n == 0) break;
      if (n < 4 || pad > 2) fail(line, what + ": the base64 data ends inside a group of four characters (cut short?)");
      const std::uint32_t b = static_cast<std::uint32_t>(q[0] << 18 | q[1] << 12 | q[2] << 6 | q[3]);
      out += static_cast<char>(b >> 16);
      if (pad < 2) out += static_cast<char>((b >> 8) & 0xff);
      if (pad < 1) out += static_cast<char>(b & 0xff);
    }
    if (used) *used = i;
    return out;
  }

  /// The bytes of a binary or appended array (its header read, its blocks inflated).
  std::string array_bytes(const ArrayRef& a) {
    const std::string what = a.what();
    if (a.format == "binary") {
      const std::string raw = base64(a.text, a.line, what);
      std::size_t at = 0;
      return payload([&](std::size_t n) {
        if (raw.size() - at < n) fail(a.line, what + ": its data holds fewer bytes than its header says (cut short?)");
        std::string out = raw.substr(at, n);
        at += n;
        return out;
      }, a.line, what);
    }
    // appended
    if (!appended_at_) fail(a.line, what + ": appended, but the file has no <AppendedData>");
    const std::size_t start = *appended_at_ + static_cast<std::size_t>(*a.offset);
    if (*a.offset < 0 || start > bytes_.size()) fail(a.line, what + ": offset " + std::to_string(*a.offset) + " lies past the file's end");
    if (appended_base64_) {
      // Decoded a quantum (3 bytes) at a time: what a take leaves of its last quantum starts the next.
      std::size_t at = start;
      std::string decoded;
      return payload([&](std::size_t n) {
        if (decoded.size() < n) {
          std::size_t used = 0;
          decoded += base64(std::string_view(bytes_).substr(at), appended_line_, what, n - decoded.size(), &used);
          at += used;
        }
        if (decoded.size() < n) fail(a.line, what + ": the appended data ends before its bytes (cut short?)");
        std::string out = decoded.substr(0, n);
        decoded.erase(0, n);
        return out;
      }, a.line, what);
    }
    std::size_t at = start;
    return payload([&](std::size_t n) {
      if (bytes_.size() - at < n) fail(a.line, what + ": the appended data ends before its bytes (cut short?)");
      std::string out = bytes_.substr(at, n);
      at += n;
      return out;
    }, a.line, what);
  }

  /// An array's header and data from `take(n)` (the next n bytes): uncompressed, the header is the
  /// data's size; with zlib, the blocks' count, size, last size and compressed sizes.
  template <class Take>
  std::string payload(Take&& take, long long line, const std::string& what) {
    auto header_value = [&] { return detail::load_bits(take(static_cast<std::size_t>(header_bytes_)).data(), header_bytes_, big_endian_); };
    if (!zlib_) {
      const std::uint64_t n = header_value();
      if (n > bytes_.size()) fail(line, what + ": its header says " + std::to_string(n) + " bytes, more than the file holds");
      return take(static_cast<std::size_t>(n));
    }
    const std::uint64_t blocks = header_value(), block_size = header_value(), last = header_value();
    if (blocks > bytes_.size() || (blocks > 0 && (block_size == 0 || last > block_size)))
      fail(line, what + ": a compressed header that the file cannot hold (" + std::to_string(blocks) + " blocks of " +
                     std::to_string(block_size) + " bytes)");
    std::vector<std::uint64_t> sizes(static_cast<std::size_t>(blocks));
    for (auto& s : sizes) {
      s = header_value();
      if (s > bytes_.size()) fail(line, what + ": a compressed block of " + std::to_string(s) + " bytes, more than the file holds");
    }
    std::string out;
    for (std::size_t b = 0; b < sizes.size(); ++b) {
      const std::string z = take(static_cast<std::size_t>(sizes[b]));
      const std::uint64_t full = (b + 1 == sizes.size() && last != 0) ? last : block_size;
      // zlib inflates by at most 1032x: a larger size is a damaged header, not an allocation to make
      if (full > 1100 * z.size() + 64)
        fail(line, what + ": compressed block " + std::to_string(b) + " of " + std::to_string(z.size()) +
                       " bytes cannot inflate to the " + std::to_string(full) + " its header says");
      std::string block(static_cast<std::size_t>(full), '\0');
      uLongf got = static_cast<uLongf>(full);
      if (uncompress(reinterpret_cast<Bytef*>(block.data()), &got, reinterpret_cast<const Bytef*>(z.data()),
                     static_cast<uLong>(z.size())) != Z_OK ||
          got != full)
        fail(line, what + ": compressed block " + std::to_string(b) + " does not inflate to its " + std::to_string(full) +
                       " bytes (a damaged file?)");
      out += block;
    }
    return out;
  }

  /// `count` values of the array as doubles (reals) or integers, checked against its type. `count`
  /// is what `source` says (at `line`: "NumberOfPoints 8", an untrusted attribute), checked against
  /// what the array's text or bytes can hold before anything is allocated. `finite` false: an ascii
  /// array's NaN and infinities are read too (as a binary one's are), for the caller to refuse.
  template <class T>
  std::vector<T> values(const ArrayRef& a, long long count, long long line, const std::string& source, bool finite = true) {
    const std::string what = a.what();
    const NumberType nt = number_type(a.type);
    if (nt.bytes == 0) fail(a.line, what + ": type '" + printable(a.type) + "' (Int8 .. UInt64, Float32, Float64)");
    if constexpr (std::is_integral_v<T>)
      if (nt.real) fail(a.line, what + ": expected an integer type, got " + a.type);
    if (a.format == "ascii") {
      // A value takes 2 bytes of text at least ("0 ").
      const std::size_t most = a.text.size() / 2 + 1;
      if (static_cast<std::size_t>(count) > most)
        fail(line, source + " needs " + std::to_string(count) + " values, more than " + what + " holds (" +
                       std::to_string(most) + " at most in its " + std::to_string(a.text.size()) +
                       " bytes of text): a count the file cannot hold");
      std::vector<T> out(static_cast<std::size_t>(count));
      detail::TextCursor c(file_, a.text, a.line);
      const std::string in = " (" + what + ")";
      for (long long i = 0; i < count; ++i) {
        const std::string_view t = c.word();
        if (t.empty())
          fail(a.line, what + ": " + std::to_string(i) + " values where " + std::to_string(count) + " are expected");
        if constexpr (std::is_integral_v<T>) out[static_cast<std::size_t>(i)] = c.to_integer(t, "an integer", LLONG_MIN / 2, LLONG_MAX / 2, in);
        else out[static_cast<std::size_t>(i)] = c.to_real(t, "a number", in, finite);
      }
      if (!c.word().empty()) fail(a.line, what + ": more than the " + std::to_string(count) + " values expected");
      return out;
    }
    const std::string b = array_bytes(a);  // no more than the file's size can hold (zlib: 1100 times it)
    if (b.size() != static_cast<std::size_t>(count) * static_cast<std::size_t>(nt.bytes))
      fail(line, source + " needs " + std::to_string(count) + " values of " + a.type + " (" + std::to_string(count * nt.bytes) +
                     " bytes), " + what + " holds " + std::to_string(b.size()) + " bytes");
    std::vector<T> out(static_cast<std::size_t>(count));
    for (std::size_t i = 0; i < out.size(); ++i) {
      const std::uint64_t u = detail::load_bits(b.data() + i * static_cast<std::size_t>(nt.bytes), nt.bytes, big_endian_);
      if constexpr (std::is_integral_v<T>) out[i] = detail::bits_as_integer(u, nt.bytes, nt.is_signed);  // (not real: checked)
      else out[i] = nt.real ? detail::bits_as_real(u, nt.bytes) : static_cast<double>(detail::bits_as_integer(u, nt.bytes, nt.is_signed));
    }
    return out;
  }

  /// Where a file has several <Piece>s (read as one mesh, their points and cells numbered on from
  /// piece to piece, as VTK and ParaView number them), the number of a piece's element `i` within
  /// its piece, for messages that name the element by its number in the file: "cell 1 of the
  /// <Piece> at line 30"; "" for a file of one piece, where the two numbers are one.
  std::string in_piece(const char* what, const Piece& p, long long i) const {
    if (!several_pieces_) return "";
    return std::string(what) + " " + std::to_string(i) + " of the <Piece> at line " + std::to_string(p.line);
  }
  /// Element `i` of the piece `p`, whose first is the file's element `first`, as messages name it:
  /// by its number in the file, then what `note` says and its number in its piece ("cell 7 (cell 1
  /// of the <Piece> at line 30)", "cell 2 (a tetrahedron, type 10)").
  std::string element(const char* what, const Piece& p, long long first, long long i, const std::string& note = {}) const {
    const std::string piece = in_piece(what, p, i);
    const std::string both = note.empty() ? piece : piece.empty() ? note : note + "; " + piece;
    return std::string(what) + " " + std::to_string(first + i) + (both.empty() ? "" : " (" + both + ")");
  }

  /// A piece's points appended to mesh_.vertices; the index of its first.
  long long read_points(const Piece& p) {
    if (!p.xyz) fail(p.line, "a <Piece> without <Points>");
    if (p.xyz->components != 3) fail(p.xyz->line, "Points: " + std::to_string(p.xyz->components) + " components, expected 3");
    const long long base = static_cast<long long>(mesh_.vertices.size());
    const std::vector<double> xyz = values<double>(*p.xyz, 3 * p.points, p.line, "NumberOfPoints " + std::to_string(p.points));
    for (long long i = 0; i < p.points; ++i) {
      const Vec3d v{xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
        fail(p.xyz->line, element("point", p, base, i) + " has a non-finite coordinate");
      mesh_.vertices.push_back(v);
    }
    return base;
  }

  /// The `count` offsets of a cell section (as the attribute `counted`, e.g. NumberOfCells, of the
  /// <Piece> at `line` says) and its connectivity, each offset checked to end a range; `cell(i)`
  /// names cell i in messages.
  template <class CellName>
  std::pair<std::vector<long long>, std::vector<long long>> cell_arrays(const std::optional<ArrayRef>& conn,
                                                                        const std::optional<ArrayRef>& offsets,
                                                                        long long count, long long line, const char* counted,
                                                                        CellName&& cell) {
    std::vector<long long> o = values<long long>(*offsets, count, line, std::string(counted) + " " + std::to_string(count));
    const long long size = count ? o.back() : 0;
    if (size < 0 || static_cast<std::size_t>(size) > bytes_.size() * 1100)
      fail(offsets->line, "offsets: the last offset " + std::to_string(size) + " is no size of a connectivity array");
    std::vector<long long> c = values<long long>(*conn, size, offsets->line, "the last offset " + std::to_string(size));
    long long begin = 0;
    for (long long i = 0; i < count; ++i) {
      const long long end = o[static_cast<std::size_t>(i)];
      if (end < begin || end > size)
        fail(offsets->line, cell(i) + ": offsets " + std::to_string(begin) + ".." + std::to_string(end) +
                                " is not a range of the " + std::to_string(size) + " connectivity entries");
      begin = end;
    }
    return {std::move(o), std::move(c)};
  }

  /// A piece's Polys or Strips as triangles of `out` (point indices after `base`).
  void polygons(const Piece& p, const CellSection& cells, const char* section, long long base, SurfaceMesh& out) {
    const long long count = cells.count;
    const std::optional<ArrayRef>& conn = cells.connectivity;
    const std::optional<ArrayRef>& offsets = cells.offsets;
    if (count == 0) return;
    if (!conn || !offsets) fail(p.line, std::string("a <Piece> whose <") + section + "> has no " + (!conn ? "connectivity" : "offsets") + " array");
    const bool strips = std::string(section) == "Strips";
    // (a piece's Polys and Strips are numbered in it: VTK numbers them after its Verts and Lines)
    auto cell = [&](long long i) {
      return std::string(section) + " cell " + std::to_string(i) + (several_pieces_ ? " of the <Piece> at line " + std::to_string(p.line) : "");
    };
    const auto [o, c] = cell_arrays(conn, offsets, count, p.line, strips ? "NumberOfStrips" : "NumberOfPolys", cell);
    std::vector<long long> corners;
    long long begin = 0;
    for (long long i = 0; i < count; ++i) {
      const long long end = o[static_cast<std::size_t>(i)];
      corners.assign(c.begin() + begin, c.begin() + end);
      begin = end;
      const std::string which = cell(i) + ": ";
      if (corners.size() < 3) fail(conn->line, which + std::to_string(corners.size()) + " points, a polygon needs 3 at least");
      for (long long& id : corners) {
        if (id < 0 || id >= p.points)
          fail(conn->line, which + "point index " + std::to_string(id) + " is out of range [0, " + std::to_string(p.points) + ")");
        id += base;
      }
      if (strips) {
        detail::append_strip(corners, out.triangles);
        continue;
      }
      if (corners.size() > 3)
        if (const int k = detail::concave_corner(corners, mesh_.vertices); k >= 0)
          fail(conn->line, which + detail::concave_message(corners.size(), corners[static_cast<std::size_t>(k)] - base));
      detail::append_fan(corners, out.triangles);
    }
  }

  void read_piece(const Piece& p) {
    if (!p.connectivity || !p.offsets || !p.types)
      fail(p.line, std::string("a <Piece> whose <Cells> has no ") +
                       (!p.connectivity ? "connectivity" : !p.offsets ? "offsets" : "types") + " array");
    const long long base = read_points(p);
    auto cell = [&](long long i, const std::string& note = {}) { return element("cell", p, cell_, i, note); };
    const auto [offsets, conn] = cell_arrays(p.connectivity, p.offsets, p.cells, p.line, "NumberOfCells",
                                             [&](long long i) { return cell(i); });
    const std::string cells = "NumberOfCells " + std::to_string(p.cells);
    const std::vector<long long> types = values<long long>(*p.types, p.cells, p.line, cells);
    std::vector<double> groups;  // an integer or a float array (is_vtk_group_tag)
    if (p.groups) groups = values<double>(*p.groups, p.cells, p.line, cells, false);
    std::map<long long, long long> other;  // volume cells of other types
    long long begin = 0;
    for (long long i = 0; i < p.cells; ++i) {
      const long long end = offsets[static_cast<std::size_t>(i)];
      const long long type = types[static_cast<std::size_t>(i)];
      const long long count = end - begin;
      const double g = p.groups ? groups[static_cast<std::size_t>(i)] : 0.0;
      if (type != detail::kVtkTet) {
        // A cell read past: its group value checked as a tet's (a volume cell of another kind is
        // refused by kind, below).
        if (detail::vtk_volume_cell(type)) ++other[type];
        else if (!detail::is_vtk_group_tag(g))
          fail(p.groups->line, detail::not_a_group_tag(detail::vtk_other_cell(cell_ + i, type, in_piece("cell", p, i)),
                                                       printable(p.groups->name), g));
        begin = end;
        continue;
      }
      if (count != 4)
        fail(p.connectivity->line, cell(i, "a tetrahedron, type 10") + " has " + std::to_string(count) + " points, expected 4");
      Tet t{};
      for (int k = 0; k < 4; ++k) {
        const long long id = conn[static_cast<std::size_t>(begin + k)];
        if (id < 0 || id >= p.points)
          fail(p.connectivity->line, cell(i) + ": point index " + std::to_string(id) + " is out of range [0, " +
                                         std::to_string(p.points) + ")" + (several_pieces_ ? " (the points of its <Piece>)" : ""));
        t[static_cast<std::size_t>(k)] = static_cast<int>(base + id);
      }
      if (!detail::is_vtk_group_tag(g)) fail(p.groups->line, detail::not_a_group_tag(cell(i), printable(p.groups->name), g));
      const int tag = static_cast<int>(g);
      mesh_.tets.push_back(t);
      mesh_.tet_group.push_back(tag);
      mesh_.file_tet_ids.push_back(cell_ + i);
      begin = end;
    }
    cell_ += p.cells;
    if (!other.empty()) {
      std::string refused;
      for (const auto& [type, n] : other) refused += (refused.empty() ? "" : ", ") + std::to_string(n) + " " + detail::vtk_volume_cell(type);
      fail(p.types->line, "the volume holds " + refused + " besides its " + std::to_string(mesh_.tets.size()) +
                              " tetrahedra: the physical mesh is 4-node tets only (mesh with tets only, first order)");
    }
  }

  std::filesystem::path file_;
  std::string bytes_;
  std::size_t pos_ = 0;
  std::size_t counted_to_ = 0;  ///< line_at's last position and its line
  long long counted_lines_ = 1;
  TetMesh mesh_;
  long long cell_ = 0;  ///< cells of the pieces before
  bool several_pieces_ = false;  ///< more than one <Piece>: messages name an element's number in its piece too
  bool surface_ = false;  ///< a PolyData (.vtp) for the virtual mesh
  bool big_endian_ = false, zlib_ = false, appended_base64_ = false;
  int header_bytes_ = 4;
  std::optional<std::size_t> appended_at_;
  long long appended_line_ = 0;
};

}  // namespace

SurfaceMesh read_vtp(const std::filesystem::path& file) {
  std::string bytes = detail::read_file_bytes(file);
  return VtuParser(file, std::move(bytes)).parse_surface();
}

TetMesh read_vtu(const std::filesystem::path& file) {
  std::string bytes = detail::read_file_bytes(file);
  return VtuParser(file, std::move(bytes)).parse();
}

}  // namespace ebh
