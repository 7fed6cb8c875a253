#pragma once
// An XDMF 3 index of a replay output's mesh snapshots, so ParaView (and VisIt) open them as a time
// series: OUT.xdmf beside OUT.h5, two temporal collections ("virtual_mesh": triangles, and
// "physical_mesh": tets), one grid per frame whose geometry is a hyperslab of
// /frames/{virtual,physical}_positions and whose topology is /mesh/{virtual_triangles,
// physical_tets}. The HDF5 file is referenced by its file name (relative), so the pair can be
// moved together. Each grid also carries the rest positions as a node attribute
// ("rest_position"), from which ParaView's Calculator gives the displacement (coords - rest_position).
#include <string>

namespace ebh {

/// OUT.h5 -> OUT.xdmf (the extension replaced; appended when there is none).
std::string xdmf_path_for(const std::string& replay_h5_path);

/// Writes the XDMF index of `replay_h5_path` atomically (write_file_atomically, io/atomic.hpp) and
/// returns its path. Throws InputError ("FILE: /frames: ...") when the file has no frames or a bad
/// layout, or when the index would replace the replay itself (io/paths.hpp check_outputs).
std::string write_xdmf(const std::string& replay_h5_path);

}  // namespace ebh
