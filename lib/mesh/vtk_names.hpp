#pragma once
// What VTK's legacy (.vtk) and XML (.vtu) files share for the physical mesh: the volume cell
// types other than the 4-node tet (refused by kind), the cell arrays that hold a cell's group and
// the values that are group tags.
// Internal to lib/mesh (the readers).
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <string>

namespace ebh::detail {

constexpr int kVtkTet = 10;  ///< VTK_TETRA

/// A volume cell type other than the 4-node tet (VTK's numbering), named for messages.
struct VtkVolumeCell {
  int type;
  const char* many;
};
inline constexpr VtkVolumeCell kVtkVolumeCells[] = {
    {11, "voxels"},           {12, "hexahedra"},          {13, "wedges (prisms)"},     {14, "pyramids"},
    {15, "pentagonal prisms"}, {16, "hexagonal prisms"},   {24, "10-node tetrahedra"},  {25, "20-node hexahedra"},
    {26, "15-node wedges"},    {27, "13-node pyramids"},   {29, "27-node hexahedra"},   {32, "18-node wedges"},
    {33, "quadratic-linear wedges"}, {42, "polyhedra"},    {71, "Lagrange tetrahedra"}, {72, "Lagrange hexahedra"},
    {73, "Lagrange wedges"},   {74, "Lagrange pyramids"},  {78, "Bezier tetrahedra"},   {79, "Bezier hexahedra"},
    {80, "Bezier wedges"},     {81, "Bezier pyramids"},
};

/// The plural name of a volume cell type other than the tet; nullptr for the tet and 0-2-D cells.
inline const char* vtk_volume_cell(long long type) {
  for (const VtkVolumeCell& c : kVtkVolumeCells)
    if (c.type == type) return c.many;
  return nullptr;
}

/// A cell of a lower dimension (VTK's numbering: a vertex, line, triangle, ...), named for messages;
/// nullptr for another type.
inline const char* vtk_lower_cell(long long type) {
  switch (type) {
    case 0: return "an empty cell";
    case 1: return "a vertex";
    case 2: return "a poly-vertex";
    case 3: return "a line";
    case 4: return "a poly-line";
    case 5: return "a triangle";
    case 6: return "a triangle strip";
    case 7: return "a polygon";
    case 8: return "a pixel";
    case 9: return "a quad";
    case 21: return "a quadratic edge";
    case 22: return "a quadratic triangle";
    case 23: return "a quadratic quad";
    case 28: return "a biquadratic quad";
    case 30: return "a quadratic-linear quad";
    case 34: return "a biquadratic triangle";
    case 35: return "a cubic line";
    case 36: return "a quadratic polygon";
    case 68: return "a Lagrange curve";
    case 69: return "a Lagrange triangle";
    case 70: return "a Lagrange quadrilateral";
    case 75: return "a Bezier curve";
    case 76: return "a Bezier triangle";
    case 77: return "a Bezier quadrilateral";
    default: return nullptr;
  }
}

/// A cell that is no tet, as messages name it: "cell 2 (a vertex, type 1)", "cell 2 (type 99)";
/// `note` (e.g. where a piece numbers it otherwise) after the type.
inline std::string vtk_other_cell(long long cell, long long type, const std::string& note = {}) {
  const char* kind = vtk_lower_cell(type);
  return "cell " + std::to_string(cell) + " (" + (kind ? std::string(kind) + ", type " : std::string("type ")) +
         std::to_string(type) + (note.empty() ? "" : "; " + note) + ")";
}

/// Whether a cell array of this name (in any case) holds each cell's region (a label, a physical
/// group): what meshio (gmsh:physical, medit:ref), 3D Slicer and VMTK (CellEntityIds) and others write.
inline bool is_vtk_group_array(const std::string& name) {
  std::string n = name;
  for (char& c : n) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  for (const char* g : {"GMSH:PHYSICAL", "CELLENTITYIDS", "MEDIT:REF", "MATERIALIDS", "MATERIAL", "REGION", "REGIONS",
                        "LABEL", "LABELS", "SUBDOMAIN", "DOMAIN"})
    if (n == g) return true;
  return false;
}

/// Whether `v`, a cell's value in a group array (read as a double, from an integer or a float
/// array: ParaView's filters, ITK and 3D Slicer write labels as Float32 or Float64), is a group
/// tag: a whole number from 0 to INT32_MAX. A fraction, a NaN or a value out of that range is not.
/// The readers check every cell's value so, a tet's and that of a cell they read past (a vertex,
/// a line, a triangle) alike: a value that is no tag is a damaged or misread array (a float array
/// written as an int, labels of another mesh), whichever cell it falls on.
inline bool is_vtk_group_tag(double v) { return v >= 0 && v <= INT32_MAX && v == std::floor(v); }

/// The error for the value `v` in the group array `array` of the cell `cell` (as messages name it:
/// "cell 3", "cell 2 (a vertex, type 1)"), which is no group tag:
/// "cell 3: CellEntityIds 1.5 is not a group tag (a whole number from 0 to 2147483647)".
inline std::string not_a_group_tag(const std::string& cell, const std::string& array, double v) {
  char buf[32];
  const auto end = std::to_chars(buf, buf + sizeof buf, v).ptr;  // the shortest form that reads back: 1.5, -1, nan
  return cell + ": " + array + " " + std::string(buf, end) + " is not a group tag (a whole number from 0 to " +
         std::to_string(INT32_MAX) + ")";
}

}  // namespace ebh::detail
