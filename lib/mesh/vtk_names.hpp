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
inline bool is_vtk_group_tag(double v) { return v >= 0 && v <= INT32_MAX && v == std::floor(v); }

/// The error for cell `cell`'s value `v` in the group array `array`, which is no group tag:
/// "cell 3: CellEntityIds 1.5 is not a group tag (a whole number from 0 to 2147483647)".
inline std::string not_a_group_tag(long long cell, const std::string& array, double v) {
  char buf[32];
  const auto end = std::to_chars(buf, buf + sizeof buf, v).ptr;  // the shortest form that reads back: 1.5, -1, nan
  return "cell " + std::to_string(cell) + ": " + array + " " + std::string(buf, end) +
         " is not a group tag (a whole number from 0 to " + std::to_string(INT32_MAX) + ")";
}

}  // namespace ebh::detail
