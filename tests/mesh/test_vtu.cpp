// VTK XML reader (.vtu) for the physical mesh: every array format gives the same tets as the ASCII
// form, and malformed or unsupported files are refused with FILE:LINE.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <utility>

#include "mesh/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "test_util.hpp"

namespace ebh {
namespace {

using test::data;
using test::expect_input_error;
using test::replace;
using test::slurp;
using test::write_temp;

TEST(ReadVtu, AsciiWithATriangleAmongTheCells) {
  const TetMesh m = read_vtu(data("mesh/cube_ascii.vtu"));
  test::expect_test_cube(m);                                           // the triangle is skipped
  EXPECT_EQ(m.file_tet_ids, (std::vector<long long>{0, 1, 3, 4, 5}));  // their cell numbers
  EXPECT_EQ(m.tet_group, (std::vector<int>{1, 1, 2, 2, 2}));          // CellEntityIds
}

TEST(ReadVtu, BinaryAndAppendedFormsGiveTheSameTets) {
  const TetMesh ascii = read_vtu(data("mesh/cube_ascii.vtu"));
  // base64 inline with zlib and UInt64 headers (meshio's default); appended base64, big-endian, zlib
  // in blocks of 16 bytes (several blocks an array, a short last one)
  for (const char* name : {"mesh/cube_binary.vtu", "mesh/cube_appended64.vtu"}) {
    SCOPED_TRACE(name);
    test::expect_same_elements(read_vtu(data(name)), ascii);
  }
  // appended raw, uncompressed, in two pieces that each hold the eight points: joined in order
  const TetMesh two = read_tet_mesh(data("mesh/cube_appended.vtu"));
  ASSERT_EQ(two.vertices.size(), 16u);
  EXPECT_EQ(two.vertices[13], ascii.vertices[5]);
  ASSERT_EQ(two.tets.size(), 5u);
  EXPECT_EQ(two.tets[1], test::kTestCubeTets[1]);
  EXPECT_EQ(two.tets[2], (Tet{5 + 8, 4 + 8, 7 + 8, 1 + 8}));
  EXPECT_EQ(two.tet_group, ascii.tet_group);
  EXPECT_EQ(two.file_tet_ids, (std::vector<long long>{0, 1, 3, 4, 5}));
}

TEST(ReadVtu, WhatVtkItselfWritesReadsAsTheLegacyFileItCameFrom) {
  // VTK 9.1's writer with its defaults (appended base64, zlib), from cube_ascii.vtk: its FieldData,
  // a vector cell array, the cells of lower dimensions, the points' InformationKey.
  const TetMesh legacy = read_vtk(data("mesh/cube_ascii.vtk"));
  const TetMesh xml = read_vtu(data("mesh/cube_vtk9.vtu"));
  test::expect_same_elements(xml, legacy);
  EXPECT_EQ(xml.file_tet_ids, legacy.file_tet_ids);
}

/// cube_appended.vtu (appended raw, little-endian, two pieces) with its CellEntityIds arrays as
/// Float32 (the same 4 bytes a value as its Int32): `first` the first piece's 2 cells, `second`
/// the second piece's 4.
std::string appended_with_float_groups(const std::vector<float>& first, const std::vector<float>& second) {
  std::string text = slurp(data("mesh/cube_appended.vtu"));
  for (int piece = 0; piece < 2; ++piece) text = replace(text, "type=\"Int32\" Name=\"CellEntityIds\"", "type=\"Float32\" Name=\"CellEntityIds\"");
  const std::size_t data_at = text.find('_', text.find("<AppendedData")) + 1;
  auto put = [&](std::size_t offset, const std::vector<float>& values) {  // after the array's UInt32 byte count
    for (std::size_t i = 0; i < values.size(); ++i)
      for (int k = 0; k < 4; ++k)
        text[data_at + offset + 4 + 4 * i + k] = static_cast<char>((std::bit_cast<std::uint32_t>(values[i]) >> (8 * k)) & 0xff);
  };
  put(0, first);     // the first piece's offset="0"
  put(302, second);  // the second's offset="302"
  return text;
}

// ParaView's filters, ITK and 3D Slicer write labels as floats: a Float32 or Float64 group array
// of whole numbers gives the groups an integer one does, ascii or binary.
TEST(ReadVtu, AFloatGroupArrayOfWholeNumbersGivesTheGroups) {
  const std::string ascii = slurp(data("mesh/cube_ascii.vtu"));
  const std::vector<int> groups = read_vtu(data("mesh/cube_ascii.vtu")).tet_group;  // {1, 1, 2, 2, 2}
  for (const std::string type : {"Float32", "Float64"}) {
    SCOPED_TRACE(type);
    const std::string text = replace(replace(ascii, "type=\"Int32\" Name=\"CellEntityIds\"", "type=\"" + type + "\" Name=\"CellEntityIds\""),
                                     "1 1 0 2 2 2", "1.0 1 0 2e0 2 2");
    EXPECT_EQ(read_vtu(write_temp("ascii.vtu", text)).tet_group, groups);
  }
  EXPECT_EQ(read_vtu(write_temp("appended.vtu", appended_with_float_groups({1, 1}, {0, 2, 2, 2}))).tet_group, groups);
  // the largest tag, and 0 on a cell that is no tet (cell 2, a triangle)
  const std::string edge = replace(replace(ascii, "type=\"Int32\" Name=\"CellEntityIds\"", "type=\"Float64\" Name=\"CellEntityIds\""),
                                   "1 1 0 2 2 2", "2147483647 1 0 2 2 2");
  EXPECT_EQ(read_vtu(write_temp("edge.vtu", edge)).tet_group, (std::vector<int>{2147483647, 1, 2, 2, 2}));
}

// A tet's float label that is no tag (a fraction, a NaN, out of range) is refused naming the file,
// the array's line, the cell, the array and the value.
TEST(ReadVtu, AFloatGroupValueThatIsNoTagIsRefusedWithItsCell) {
  const std::string doubles = replace(slurp(data("mesh/cube_ascii.vtu")), "type=\"Int32\" Name=\"CellEntityIds\"",
                                      "type=\"Float64\" Name=\"CellEntityIds\"");
  for (const auto& [value, shown] : {std::pair{"1.5", "1.5"}, std::pair{"nan", "nan"}, std::pair{"-1", "-1"},
                                     std::pair{"2147483648", "2147483648"}, std::pair{"3e9", "3e+09"}}) {
    SCOPED_TRACE(value);
    const auto p = write_temp("bad.vtu", replace(doubles, "1 1 0 2 2 2", std::string("1 ") + value + " 0 2 2 2"));
    expect_input_error([&] { read_vtu(p); }, p, 9, std::string("cell 1: CellEntityIds ") + shown + " is not a group tag (a whole number from 0 to 2147483647)");
  }
  // binary: the second piece's cell 1, the file's cell 3 (its array's line)
  const auto p = write_temp("appended.vtu", appended_with_float_groups({1, 1}, {0, std::nanf(""), 2, 2}));
  expect_input_error([&] { read_vtu(p); }, p, 24, "cell 3 (cell 1 of the <Piece> at line 20): CellEntityIds nan is not a group tag");
}

// A value in the group array on a cell that is no tet (a triangle, read past) is checked as a
// tet's is, naming the cell and its kind.
TEST(ReadVtu, AGroupValueOnACellThatIsNoTetIsCheckedAsATetsIs) {
  const std::string ascii = slurp(data("mesh/cube_ascii.vtu"));  // cell 2 is a triangle
  const std::string doubles = replace(ascii, "type=\"Int32\" Name=\"CellEntityIds\"", "type=\"Float64\" Name=\"CellEntityIds\"");
  test::expect_each_refused(
      {
          {"nan.vtu", replace(doubles, "1 1 0 2 2 2", "1 1 nan 2 2 2"), 9,
           "cell 2 (a triangle, type 5): CellEntityIds nan is not a group tag (a whole number from 0 to 2147483647)"},
          {"fraction.vtu", replace(doubles, "1 1 0 2 2 2", "1 1 0.25 2 2 2"), 9, "cell 2 (a triangle, type 5): CellEntityIds 0.25 is not"},
          {"negative.vtu", replace(ascii, "1 1 0 2 2 2", "1 1 -3 2 2 2"), 9, "cell 2 (a triangle, type 5): CellEntityIds -3 is not"},
          // a vertex (type 1) in its place
          {"vertex.vtu",
           replace(replace(replace(replace(doubles, "10 10 5 10 10 10", "10 10 1 10 10 10"), "4 8 11 15 19 23", "4 8 9 13 17 21"),
                           "0 1 2 4 3 2 1 7 0 2 1 5", "0 1 2 4 3 2 1 7 0 5"),
                   "1 1 0 2 2 2", "1 1 1e10 2 2 2"),
           9, "cell 2 (a vertex, type 1): CellEntityIds 1e+10 is not"},
      },
      [](const auto& p) { read_vtu(p); });
}

/// `ascii` (cube_ascii.vtu) with its <Piece> twice, `from` replaced by `to` in the second: 16 points
/// and 12 cells, the second <Piece> at line 30 and each of its arrays 25 lines below the first's.
std::string two_pieces(const std::string& ascii, const std::string& from = {}, const std::string& to = {}) {
  const std::string close = "    </Piece>\n";
  const std::size_t begin = ascii.find("    <Piece"), end = ascii.find(close) + close.size();
  const std::string piece = ascii.substr(begin, end - begin);
  return ascii.substr(0, end) + (from.empty() ? piece : replace(piece, from, to)) + ascii.substr(end);
}

// In a file of several <Piece>s (read as one mesh), a message names a cell or a point by its number
// in the file, the pieces' counted in turn as VTK and ParaView number them, and by its number in
// its <Piece>: the user finds it either way.
TEST(ReadVtu, ErrorsInALaterPieceNameTheCellByItsNumberInTheFile) {
  const std::string ascii = slurp(data("mesh/cube_ascii.vtu"));
  const TetMesh two = read_vtu(write_temp("two.vtu", two_pieces(ascii)));
  EXPECT_EQ(two.file_tet_ids, (std::vector<long long>{0, 1, 3, 4, 5, 6, 7, 9, 10, 11}));
  test::expect_each_refused(
      {
          {"group.vtu", two_pieces(ascii, "1 1 0 2 2 2", "1 -1 0 2 2 2"), 34,
           "cell 7 (cell 1 of the <Piece> at line 30): CellEntityIds -1 is not a group tag"},
          {"range.vtu", two_pieces(ascii, "0 1 2 4 3 2 1 7", "0 1 2 9 3 2 1 7"), 44,
           "cell 6 (cell 0 of the <Piece> at line 30): point index 9 is out of range [0, 8) (the points of its <Piece>)"},
          {"offsets.vtu", two_pieces(ascii, "4 8 11 15 19 23", "4 8 16 20 19 23"), 47,
           "cell 10 (cell 4 of the <Piece> at line 30): offsets 20..19 is not a range of the 23 connectivity entries"},
          {"points.vtu", two_pieces(ascii, "10 10 5 10 10 10", "10 10 10 10 10 10"), 44,
           "cell 8 (a tetrahedron, type 10; cell 2 of the <Piece> at line 30) has 3 points, expected 4"},
          {"triangle.vtu", two_pieces(replace(ascii, "type=\"Int32\" Name=\"CellEntityIds\"", "type=\"Float32\" Name=\"CellEntityIds\""),
                                      "1 1 0 2 2 2", "1 1 nan 2 2 2"),
           34, "cell 8 (a triangle, type 5; cell 2 of the <Piece> at line 30): CellEntityIds nan is not a group tag"},
      },
      [](const auto& p) { read_vtu(p); });
  // binary (cube_appended.vtu: two pieces of 8 points, 2 and 4 cells): the second piece's point 5
  // is the file's point 13
  std::string raw = slurp(data("mesh/cube_appended.vtu"));
  const std::size_t y = raw.find('_', raw.find("<AppendedData")) + 1 + 322 + 4 + (3 * 5 + 1) * 8;  // offset 322, a UInt32 header
  const auto nan = std::bit_cast<std::uint64_t>(std::nan(""));
  for (int k = 0; k < 8; ++k) raw[y + static_cast<std::size_t>(k)] = static_cast<char>((nan >> (8 * k)) & 0xff);  // little-endian
  const auto p = write_temp("point.vtu", raw);
  expect_input_error([&] { read_vtu(p); }, p, 27, "point 13 (point 5 of the <Piece> at line 20) has a non-finite coordinate");
}

TEST(ReadVtu, MalformedAndUnsupportedFilesAreRefusedWithTheirLine) {
  const std::string ascii = slurp(data("mesh/cube_ascii.vtu"));
  const std::string binary = slurp(data("mesh/cube_binary.vtu"));
  const std::string raw = slurp(data("mesh/cube_appended.vtu"));
  const std::vector<test::BadFile> cases = {
      {"not_xml.vtu", "# vtk DataFile Version 3.0\n", 1, "not a VTK XML file"},
      {"parallel.pvtu", replace(ascii, "type=\"UnstructuredGrid\"", "type=\"PUnstructuredGrid\""), 3,
       "(a parallel file that names its pieces: merge them"},
      {"image.vtu", replace(ascii, "type=\"UnstructuredGrid\"", "type=\"ImageData\""), 3,
       "a VTKFile of type 'ImageData' holds no tetrahedra"},
      {"lz4.vtu", replace(ascii, "header_type=\"UInt32\"", "header_type=\"UInt32\" compressor=\"vtkLZ4DataCompressor\""), 3,
       "compressor 'vtkLZ4DataCompressor' is not read"},
      {"hex.vtu", replace(replace(ascii, "10 10 5 10 10 10", "10 10 12 10 10 10"), "4 8 11 15", "4 8 16 20"), 22,
       "cell 4: offsets 20..19 is not a range of the 23 connectivity entries"},
      {"hex_fits.vtu", replace(ascii, "10 10 5 10 10 10", "10 10 14 10 10 10"), 25,
       "the volume holds 1 pyramids besides its 5 tetrahedra"},
      {"range.vtu", replace(ascii, "0 1 2 4 3 2 1 7", "0 1 2 9 3 2 1 7"), 19, "cell 0: point index 9 is out of range [0, 8)"},
      {"nan.vtu", replace(ascii, "10 10 10\n", "10 nan 10\n"), 15, "a number 'nan' is not a finite number (DataArray Float64)"},
      {"few.vtu", replace(ascii, "1 1 0 2 2 2", "1 1 0 2 2"), 9, "DataArray CellEntityIds: 5 values where 6 are expected"},
      {"negative.vtu", replace(ascii, "1 1 0 2 2 2", "1 -1 0 2 2 2"), 9, "cell 1: CellEntityIds -1 is not a group tag"},
      {"no_types.vtu", replace(ascii, "Name=\"types\"", "Name=\"kinds\""), 5, "whose <Cells> has no types array"},
      {"open.vtu", ascii.substr(0, ascii.find("</UnstructuredGrid>")), 29, "the file ends before </VTKFile>"},
      {"attr.vtu", replace(ascii, "NumberOfCells=\"6\"", "NumberOfCells=6"), 5, "attribute NumberOfCells has no quoted value"},
      {"count.vtu", replace(ascii, "NumberOfCells=\"6\"", "NumberOfCells=\"-6\""), 5, "NumberOfCells '-6' is not a whole number"},
      {"base64.vtu", replace(binary, "format=\"binary\">AQAAAAAAAAAAgAAAAAAAABgAAAAAAAAAEgAAAAAAAAA=eJ",
                             "format=\"binary\">AQAAAAAAAAAAgAAAAAAAABgAAAAAAAAAEgAAAAAAAAA=e*"),
       9, "'*' in base64 data"},
      {"zlib.vtu", replace(binary, "AAAAAAA=eJxjZGBgYGSAACYkDAAAdAAJ", "AAAAAAA=eJxjZGBgYGSAACYkDAAAdAAA"), 9,
       "compressed block 0 does not inflate to its 24 bytes"},
      {"short.vtu", raw.substr(0, raw.size() - 60), 31, "DataArray offsets: the appended data ends before its bytes (cut short?)"},
      {"no_appended.vtu", raw.substr(0, raw.find("  <AppendedData")) + "</VTKFile>\n", 12, "appended, but the file has no <AppendedData>"},
  };
  test::expect_each_refused(cases, [](const auto& p) { read_tet_mesh(p); });
}

// The peak resident memory of this process so far, in KiB.
long peak_rss_kib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

// A Piece's counts are untrusted: a 2 KB file that declares 300 million points is refused at the
// <Piece>'s line, naming the count, before any array of that size is made (it took 7 GB).
TEST(ReadVtu, CountsTheArraysCannotHoldAreRefusedBeforeAnythingIsSized) {
  const std::string ascii = slurp(data("mesh/cube_ascii.vtu"));
  const std::string binary = slurp(data("mesh/cube_binary.vtu"));
  const std::string raw = slurp(data("mesh/cube_appended.vtu"));
  const std::string poly = slurp(data("mesh/cube_poly.vtp"));
  const long before = peak_rss_kib();
  test::expect_each_refused(
      {
          {"points.vtu", replace(ascii, "NumberOfPoints=\"8\"", "NumberOfPoints=\"300000000\""), 5,
           "NumberOfPoints 300000000 needs 900000000 values, more than DataArray Float64 holds ("},
          {"most.vtu", replace(ascii, "NumberOfPoints=\"8\"", "NumberOfPoints=\"2147483646\""), 5,
           "NumberOfPoints 2147483646 needs 6442450938 values, more than"},
          {"cells.vtu", replace(binary, "NumberOfCells=\"6\"", "NumberOfCells=\"400000000\""), 5,
           "NumberOfCells 400000000 needs 400000000 values of Int64 (3200000000 bytes), DataArray offsets holds 48 bytes"},
          {"raw.vtu", replace(raw, "NumberOfPoints=\"8\"", "NumberOfPoints=\"300000000\""), 5,
           "NumberOfPoints 300000000 needs 900000000 values of Float64 (7200000000 bytes), DataArray Float64 holds 192 bytes"},
      },
      [](const auto& p) { read_tet_mesh(p); });
  test::expect_each_refused({{"polys.vtp", replace(poly, "NumberOfPolys=\"5\"", "NumberOfPolys=\"200000000\""), 4,
                              "NumberOfPolys 200000000 needs 200000000 values of Int64 (1600000000 bytes), DataArray offsets holds 40 bytes"}},
                            [](const auto& p) { read_surface(p); });
  EXPECT_LT(peak_rss_kib() - before, 256 * 1024) << "KiB more at the peak";
}

}  // namespace
}  // namespace ebh
