#include "render/xdmf.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.hpp"
#include "ebh/version.hpp"
#include "io/atomic.hpp"
#include "io/paths.hpp"
#include "render/replay_frames.hpp"

namespace ebh {
namespace fs = std::filesystem;

namespace {

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

struct MeshSeries {
  const char* name;         // grid name
  const char* topology;     // XDMF TopologyType
  int nodes_per_element;
  std::size_t elements;
  const char* cells;        // /mesh/... dataset of the cells
  std::size_t vertices;
  const char* positions;    // /frames/... dataset of the positions
  const char* rest;         // /mesh/... dataset of the rest positions
};

void write_series(std::ostream& o, const MeshSeries& s, const std::string& h5, const std::vector<double>& t) {
  const std::size_t F = t.size();
  o << "    <Grid Name=\"" << s.name << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (std::size_t f = 0; f < F; ++f) {
    char time[40];
    std::snprintf(time, sizeof time, "%.9g", t[f]);
    o << "      <Grid Name=\"" << s.name << "_" << f << "\" GridType=\"Uniform\">\n"
      << "        <Time Value=\"" << time << "\"/>\n"
      << "        <Topology TopologyType=\"" << s.topology << "\" NumberOfElements=\"" << s.elements
      << "\" NodesPerElement=\"" << s.nodes_per_element << "\">\n"
      << "          <DataItem Dimensions=\"" << s.elements << " " << s.nodes_per_element
      << "\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">" << h5 << ":" << s.cells << "</DataItem>\n"
      << "        </Topology>\n"
      << "        <Geometry GeometryType=\"XYZ\">\n"
      << "          <DataItem ItemType=\"HyperSlab\" Dimensions=\"1 " << s.vertices << " 3\" Type=\"HyperSlab\">\n"
      << "            <DataItem Dimensions=\"3 3\" NumberType=\"Int\" Format=\"XML\">" << f << " 0 0 1 1 1 1 "
      << s.vertices << " 3</DataItem>\n"
      << "            <DataItem Dimensions=\"" << F << " " << s.vertices << " 3\" NumberType=\"Float\" Precision=\"4\" "
      << "Format=\"HDF\">" << h5 << ":" << s.positions << "</DataItem>\n"
      << "          </DataItem>\n"
      << "        </Geometry>\n"
      << "        <Attribute Name=\"rest_position\" AttributeType=\"Vector\" Center=\"Node\">\n"
      << "          <DataItem Dimensions=\"" << s.vertices << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">"
      << h5 << ":" << s.rest << "</DataItem>\n"
      << "        </Attribute>\n"
      << "      </Grid>\n";
  }
  o << "    </Grid>\n";
}

}  // namespace

std::string xdmf_path_for(const std::string& replay_h5_path) {
  fs::path p(replay_h5_path);
  p.replace_extension(".xdmf");
  return p.string();
}

std::string write_xdmf(const std::string& replay_h5_path) {
  const std::string out_path = xdmf_path_for(replay_h5_path);
  check_outputs({{out_path, "the XDMF index"}}, {{replay_h5_path, "the replay"}});
  const ReplayFrames frames = open_replay_frames(replay_h5_path);
  const std::string h5 = xml_escape(fs::path(replay_h5_path).filename().string());

  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
    << "<!-- ebh " << kVersion << ": the mesh snapshots of " << h5 << " (" << frames.frame_count()
    << " frames) as time series; open this file in ParaView (Xdmf3 reader). docs/RENDER.md -->\n"
    << "<Xdmf Version=\"3.0\">\n  <Domain>\n";
  write_series(o, {"virtual_mesh", "Triangle", 3, frames.triangles.size(), "/mesh/virtual_triangles",
                   frames.virtual_vertices(), "/frames/virtual_positions", "/mesh/virtual_rest"},
               h5, frames.t);
  write_series(o, {"physical_mesh", "Tetrahedron", 4, frames.physical_tets, "/mesh/physical_tets",
                   frames.physical_vertices, "/frames/physical_positions", "/mesh/physical_rest"},
               h5, frames.t);
  o << "  </Domain>\n</Xdmf>\n";

  write_file_atomically(out_path, o.str());
  return out_path;
}

}  // namespace ebh
