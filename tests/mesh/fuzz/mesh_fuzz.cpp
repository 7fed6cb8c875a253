// Mutation test of the mesh readers: valid MSH 2.2 / 4.1, VTK, Medit, TetGen, OBJ, STL and PLY files are mutated at random
// (fixed seed: every run is the same) and each result must either read or throw InputError; a
// surface that reads must name only vertices it has.
// Built with AddressSanitizer and UBSan (tests/fuzz.cmake), so an out-of-bounds read, an overflow
// or an allocation sized by an absurd count fails the run. Whatever reads is also passed through
// the validator and boundary extraction, which must cope with any mesh the readers return.
//
// usage: test_mesh_fuzz DATA_DIR [MUTATIONS]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/error.hpp"
#include "mesh/boundary.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/quality.hpp"

namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

using Rng = std::mt19937_64;

std::size_t pick(Rng& rng, std::size_t n) { return n == 0 ? 0 : std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); }

/// Line starts of `s` (always at least one).
std::vector<std::size_t> line_starts(const std::string& s) {
  std::vector<std::size_t> starts{0};
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s[i] == '\n' && i + 1 < s.size()) starts.push_back(i + 1);
  return starts;
}

void mutate_once(std::string& s, Rng& rng) {
  static const char* kNumbers[] = {"999999999999", "2147483647", "2147483648", "-1", "0", "-2147483649",
                                   "9223372036854775807", "99999999999999999999999", "1e308", "1e999", "nan",
                                   "-0", "4611686018427387905", "3"};
  switch (pick(rng, 7)) {
    case 0:  // truncate
      s.resize(pick(rng, s.size() + 1));
      break;
    case 1: {  // garbage bytes
      const std::size_t n = 1 + pick(rng, 8);
      for (std::size_t k = 0; k < n && !s.empty(); ++k) s[pick(rng, s.size())] = static_cast<char>(pick(rng, 256));
      break;
    }
    case 2: {  // a digit string replaced by a huge or odd number
      std::vector<std::pair<std::size_t, std::size_t>> runs;
      for (std::size_t i = 0; i < s.size();) {
        if (s[i] >= '0' && s[i] <= '9') {
          std::size_t j = i;
          while (j < s.size() && s[j] >= '0' && s[j] <= '9') ++j;
          runs.emplace_back(i, j - i);
          i = j;
        } else {
          ++i;
        }
      }
      if (runs.empty()) break;
      const auto [at, len] = runs[pick(rng, runs.size())];
      s.replace(at, len, kNumbers[pick(rng, sizeof kNumbers / sizeof *kNumbers)]);
      break;
    }
    case 3: {  // a line duplicated
      const auto starts = line_starts(s);
      const std::size_t l = pick(rng, starts.size());
      const std::size_t end = l + 1 < starts.size() ? starts[l + 1] : s.size();
      s.insert(end, s.substr(starts[l], end - starts[l]));
      break;
    }
    case 4: {  // a line deleted
      const auto starts = line_starts(s);
      const std::size_t l = pick(rng, starts.size());
      const std::size_t end = l + 1 < starts.size() ? starts[l + 1] : s.size();
      s.erase(starts[l], end - starts[l]);
      break;
    }
    case 5: {  // a run of up to 12 lines copied to another line's start (a section given twice)
      const auto starts = line_starts(s);
      const std::size_t l = pick(rng, starts.size());
      const std::size_t n = std::min(starts.size() - l, 1 + pick(rng, 12));
      const std::size_t end = l + n < starts.size() ? starts[l + n] : s.size();
      const std::string run = s.substr(starts[l], end - starts[l]);
      s.insert(starts[pick(rng, starts.size())], run + (run.ends_with('\n') ? "" : "\n"));
      break;
    }
    default: {  // a byte inserted (white space, a sign, a newline or anything)
      static const char kBytes[] = {' ', '\n', '\r', '-', '+', '.', '$', '"', '/', '\0', 'e'};
      s.insert(pick(rng, s.size() + 1), 1, kBytes[pick(rng, sizeof kBytes)]);
      break;
    }
  }
}

/// A surface by the format's own reader (not read_surface, which holds every index to the
/// vertices: this checks the readers themselves), by the seed's extension.
ebh::SurfaceMesh read_surface_format(const fs::path& file, const std::string& ext) {
  if (ext == ".obj") return ebh::read_obj(file);
  if (ext == ".stl") return ebh::read_stl(file);
  if (ext == ".ply") return ebh::read_ply(file);
  if (ext == ".vtp") return ebh::read_vtp(file);
  return ebh::read_vtk_surface(file);
}

/// The first triangle corner of `s` that names no vertex, as "triangle N: vertex index V of #V"; empty
/// where there is none (whatever a surface reader returns is indexed by the scene).
std::string bad_corner(const ebh::SurfaceMesh& s) {
  for (std::size_t i = 0; i < s.triangles.size(); ++i)
    for (const int v : s.triangles[i])
      if (v < 0 || static_cast<std::size_t>(v) >= s.vertices.size())
        return "triangle " + std::to_string(i) + ": vertex index " + std::to_string(v) + " of " + std::to_string(s.vertices.size());
  return {};
}

/// Runs everything that consumes a freshly read mesh.
void exercise(ebh::TetMesh& m) {
  const ebh::MeshReport r = ebh::validate_mesh(m);
  (void)r.fatal_message(m);
  (void)r.warnings();
  if (r.bad_index_tets.empty()) {
    std::vector<int> map;
    (void)ebh::extract_boundary(m, &map);
    (void)ebh::orient_tets(m);
    (void)ebh::remove_unreferenced_vertices(m);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: test_mesh_fuzz DATA_DIR [MUTATIONS]\n");
    return 2;
  }
  const fs::path dir = argv[1];
  const long mutations = argc > 2 ? std::atol(argv[2]) : 4000;
  const std::vector<fs::path> seeds = {dir / "cube22.msh",      dir / "cube41.msh",      dir / "cube.obj",
                                       dir / "cube_ascii.stl",  dir / "cube_binary.stl", dir / "cube_ascii.vtk",
                                       dir / "cube_binary.vtk", dir / "cube51.vtk",      dir / "cube.mesh",
                                       dir / "cube.1.node",     dir / "cube.1.ele",      dir / "cube.1.face",
                                       dir / "cube_ascii.vtu",  dir / "cube_binary.vtu", dir / "cube_appended64.vtu",
                                       dir / "cube_vtk9.vtu",   dir / "cube.ply",        dir / "cube_le.ply",
                                       dir / "cube_be.ply",     dir / "cube_poly.vtk",   dir / "cube_poly.vtp",
                                       dir / "cube_poly_vtk9.vtk"};
  std::vector<std::string> texts;
  for (const auto& p : seeds) {
    texts.push_back(slurp(p));
    if (texts.back().empty()) {
      std::fprintf(stderr, "test_mesh_fuzz: cannot read %s\n", p.string().c_str());
      return 2;
    }
  }
  // a memory-backed folder where there is one: the loop writes a file per mutation
  std::error_code ec;
  const fs::path tmp = fs::is_directory("/dev/shm", ec) ? fs::path("/dev/shm") : fs::temp_directory_path();
  const fs::path work = tmp / ("ebh_mesh_fuzz_" + std::to_string(::getpid()));
  fs::create_directories(work);
  Rng rng(20240607);  // fixed: the same mutations every run
  long read_ok = 0, rejected = 0;
  int status = 0;
  for (long i = 0; i < mutations && status == 0; ++i) {
    const std::size_t which = static_cast<std::size_t>(i) % seeds.size();
    std::string text = texts[which];
    const std::size_t rounds = 1 + pick(rng, 3);
    for (std::size_t k = 0; k < rounds; ++k) mutate_once(text, rng);
    const fs::path file = work / seeds[which].filename();
    // A TetGen mesh is three files: the other two beside the mutated one, as they are.
    const std::string stem = seeds[which].stem().string();
    for (std::size_t k = 0; k < seeds.size(); ++k)
      if (k != which && seeds[k].stem().string() == stem) std::ofstream(work / seeds[k].filename(), std::ios::binary | std::ios::trunc) << texts[k];
    std::ofstream(file, std::ios::binary | std::ios::trunc) << text;
    const std::string ext = seeds[which].extension().string();
    try {
      // surfaces: OBJ, STL, PLY and VTK polydata (legacy .vtk files named *_poly*)
      const bool polydata = ext == ".vtp" || seeds[which].filename().string().find("_poly") != std::string::npos;
      if (ext == ".obj" || ext == ".stl" || ext == ".ply" || polydata) {
        if (const std::string bad = bad_corner(read_surface_format(file, ext)); !bad.empty()) {
          std::fprintf(stderr, "mutation %ld of %s: read with %s (input kept in %s)\n", i,
                       seeds[which].filename().string().c_str(), bad.c_str(), file.string().c_str());
          status = 1;
        }
      } else {
        // read_tet_mesh reads a .face through its .ele
        ebh::TetMesh m = ebh::read_tet_mesh(ext == ".face" ? fs::path(file).replace_extension(".ele") : file);
        exercise(m);
      }
      ++read_ok;
    } catch (const ebh::InputError& e) {
      const std::string msg = e.what();
      // An error names the file it is in: for a TetGen mesh, one of its three.
      const bool tetgen = ext == ".node" || ext == ".ele" || ext == ".face";
      const std::string named = tetgen ? (work / stem).string() + "." : file.string() + ":";
      if (msg.find('\n') != std::string::npos || msg.rfind(named, 0) != 0) {
        std::fprintf(stderr, "mutation %ld: badly formed message: %s\n", i, msg.c_str());
        status = 1;
      }
      ++rejected;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "mutation %ld of %s: %s instead of InputError (input kept in %s)\n", i,
                   seeds[which].filename().string().c_str(), e.what(), file.string().c_str());
      status = 1;
    }
  }
  std::printf("test_mesh_fuzz: %ld mutations: %ld read, %ld rejected with InputError\n", read_ok + rejected, read_ok, rejected);
  if (status == 0) fs::remove_all(work);
  return status;
}
