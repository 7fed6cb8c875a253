#pragma once
// Helpers for the mesh tests: temporary files and InputError checks.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "mesh/box_mesh.hpp"
#include "mesh/quality.hpp"
#include "mesh/tet_mesh.hpp"

namespace ebh::test {

inline std::filesystem::path data(const std::string& name) { return std::filesystem::path(EBH_TEST_DATA_DIR) / name; }

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The InputError of `read(p)` with the file `p` made unreadable (no permissions), then readable
/// again; nullopt where the file opens all the same (as root), where the test has nothing to check.
template <class Read>
std::optional<std::string> error_when_unreadable(const std::filesystem::path& p, Read read) {
  namespace fs = std::filesystem;
  fs::permissions(p, fs::perms::none);
  const bool opens = static_cast<bool>(std::ifstream(p));
  std::string message = "no error";
  if (!opens) {
    try {
      read(p);
    } catch (const InputError& e) {
      message = e.what();
    }
  }
  fs::permissions(p, fs::perms::owner_read | fs::perms::owner_write);
  if (opens) return std::nullopt;
  return message;
}

/// A block of `size` x `size` x size/5 in 1200 tets (10 x 10 x 2 cells) with a speck of 6 tets, a
/// cube of size/50, at 2/5 of its size above it: a segmentation's noise apart from the organ. The
/// speck's vertices follow the block's.
inline TetMesh block_with_a_speck(double size) {
  TetMesh mesh = make_box_tets({0, 0, 0}, {size, size, size / 5}, 10, 10, 2);
  const double at = 0.4 * size;
  const TetMesh speck = make_box_tets({at, at, at}, {at + size / 50, at + size / 50, at + size / 50}, 1, 1, 1);
  const int nv = static_cast<int>(mesh.vertices.size());
  mesh.vertices.insert(mesh.vertices.end(), speck.vertices.begin(), speck.vertices.end());
  for (const Tet& t : speck.tets) mesh.tets.push_back({t[0] + nv, t[1] + nv, t[2] + nv, t[3] + nv});
  mesh.tet_group.assign(mesh.tets.size(), 0);
  return mesh;
}

/// Writes `text` to a fresh file in the test's temporary folder and returns its path.
inline std::filesystem::path write_temp(const std::string& name, const std::string& text) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  auto dir = std::filesystem::path(::testing::TempDir()) / "ebh_mesh_tests" / info->test_suite_name() / info->name();
  std::filesystem::create_directories(dir);
  auto p = dir / name;
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

/// The same vertices (to the bit), tets, triangles and groups (file ids aside).
inline void expect_same_elements(const TetMesh& a, const TetMesh& b) {
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  for (std::size_t i = 0; i < a.vertices.size(); ++i) EXPECT_EQ(a.vertices[i], b.vertices[i]) << "vertex " << i;
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.tet_group, b.tet_group);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.triangle_group, b.triangle_group);
  EXPECT_EQ(a.group_names, b.group_names);
  EXPECT_EQ(a.tet_more_groups, b.tet_more_groups);
  EXPECT_EQ(a.triangle_more_groups, b.triangle_more_groups);
}

/// Replaces the first occurrence of `from` in `text` (which must contain it).
inline std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test fixture does not contain '" << from << "'";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

/// Runs `f`, expecting an InputError whose message starts with "FILE:LINE: " and contains
/// `needle`; returns the message.
template <class F>
std::string expect_input_error(F&& f, const std::filesystem::path& file, int line, const std::string& needle) {
  try {
    f();
  } catch (const InputError& e) {
    const std::string msg = e.what();
    const std::string prefix = file.string() + ":" + std::to_string(line) + ": ";
    EXPECT_EQ(msg.rfind(prefix, 0), 0u) << "message: " << msg << "\nexpected prefix: " << prefix;
    EXPECT_NE(msg.find(needle), std::string::npos) << "message: " << msg << "\nexpected to contain: " << needle;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "message is not one line: " << msg;
    return msg;
  }
  ADD_FAILURE() << "no InputError thrown (expected one containing '" << needle << "')";
  return {};
}

/// The cube of make_test_meshes.py (corner c = x + 2y + 4z at (10 x, 10 y, 10 z)) as the files
/// that list its corners in that order (Medit, TetGen, VTK XML) hold its five tets.
inline const std::vector<Tet> kTestCubeTets = {{0, 1, 2, 4}, {3, 2, 1, 7}, {5, 4, 7, 1}, {6, 7, 4, 2}, {1, 2, 4, 7}};

/// `m` is that cube: its corners in order, its tets, a valid mesh of 12 boundary faces.
inline void expect_test_cube(const TetMesh& m) {
  ASSERT_EQ(m.vertices.size(), 8u);
  for (int c = 0; c < 8; ++c)
    EXPECT_EQ(m.vertices[static_cast<std::size_t>(c)], Vec3d(10.0 * (c & 1), 10.0 * ((c >> 1) & 1), 10.0 * ((c >> 2) & 1)));
  EXPECT_EQ(m.tets, kTestCubeTets);
  const MeshReport r = validate_mesh(m);
  EXPECT_FALSE(r.fatal()) << r.fatal_message(m);
  EXPECT_EQ(r.boundary_faces, 12);
}

/// A malformed file: its name, its text, the line its error names and a part of the message.
struct BadFile {
  std::string name, text;
  int line;
  std::string needle;
};

/// Writes each bad file and expects `read(path)` to refuse it with an InputError "FILE:LINE: ..."
/// holding its needle.
template <class Read>
void expect_each_refused(const std::vector<BadFile>& cases, Read&& read) {
  for (const BadFile& c : cases) {
    SCOPED_TRACE(c.name);
    const auto p = write_temp(c.name, c.text);
    expect_input_error([&] { read(p); }, p, c.line, c.needle);
  }
}

}  // namespace ebh::test
