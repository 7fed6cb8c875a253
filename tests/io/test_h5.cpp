#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <vector>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "io/atomic.hpp"
#include "io/h5.hpp"
#include "io_test_util.hpp"

using namespace ebh;
namespace fs = std::filesystem;

TEST(H5, DatasetsAndAttributesRoundTrip) {
  test::ScratchDir tmp;
  const std::string path = tmp / "a.h5";
  {
    h5::File f = h5::File::create(path);
    std::vector<double> d{1, 2, 3, 4, 5, 6};
    std::vector<float> fl{0.5f, 1.5f};
    std::vector<std::int32_t> ints{-1, 7, 9};
    std::vector<std::uint8_t> bytes{0, 255};
    f.write<double>("g/sub/d", d, {2, 3}).set_attr("unit", "m");
    f.write<float>("f", fl, {2}, {.compress = true});
    f.write<std::int32_t>("i", ints, {3});
    f.write<std::uint8_t>("u", bytes, {2});
    f.set_attr("rate_hz", 1000.0);
    f.set_attr("count", 42);
    f.set_attr("name", "tube");
    f.set_attr("v", std::vector<double>{1.5, 2.5});
  }
  h5::File f = h5::File::open_read(path);
  auto d = f.read<double>("g/sub/d", {-1, 3});
  EXPECT_EQ(d.shape, (std::vector<std::size_t>{2, 3}));
  EXPECT_EQ(d.data, (std::vector<double>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(f.group("g").group("sub").dataset("d").attr_string("unit"), "m");
  EXPECT_EQ(f.read<float>("f").data, (std::vector<float>{0.5f, 1.5f}));
  EXPECT_EQ(f.read<double>("f").data, (std::vector<double>{0.5, 1.5}));  // width converted
  EXPECT_EQ(f.read<std::int32_t>("i").data, (std::vector<std::int32_t>{-1, 7, 9}));
  EXPECT_EQ(f.read<std::uint8_t>("u").data, (std::vector<std::uint8_t>{0, 255}));
  EXPECT_EQ(f.attr_double("rate_hz"), 1000.0);
  EXPECT_EQ(f.attr_int("count"), 42);
  EXPECT_EQ(f.attr_string("name"), "tube");
  EXPECT_EQ(f.attr_doubles("v"), (std::vector<double>{1.5, 2.5}));
  EXPECT_TRUE(f.has("g/sub/d"));
  EXPECT_FALSE(f.has("g/nope/d"));
}

TEST(H5, StringDatasetsRoundTrip) {
  test::ScratchDir tmp;
  const std::string path = tmp / "s.h5";
  const std::vector<std::string> v{"tube", "", "a, \"quoted\" value\nwith a line break", "\xc2\xb5m"};
  {
    h5::File f = h5::File::create(path);
    f.write_strings("names", v).set_attr("unit", "1");
    f.write_strings("g/none", {});
    f.write<double>("x", std::vector<double>{1}, {1});
  }
  h5::File f = h5::File::open_read(path);
  EXPECT_EQ(f.dataset("names").read_strings(), v);
  EXPECT_EQ(f.dataset("names").shape(), (std::vector<std::size_t>{4}));
  EXPECT_TRUE(f.dataset("g/none").read_strings().empty());
  EXPECT_INPUT_ERROR(f.dataset("x").read_strings(), path, "/x", "not a dataset of strings");
  EXPECT_INPUT_ERROR(f.read<double>("names"), path, "/names", "type string");
}

TEST(H5, ErrorsNameFileAndObject) {
  test::ScratchDir tmp;
  const std::string path = tmp / "b.h5";
  {
    h5::File f = h5::File::create(path);
    f.write<double>("x", std::vector<double>{1, 2, 3, 4}, {2, 2});
    f.write<std::int32_t>("n", std::vector<std::int32_t>{1}, {1});
  }
  h5::File f = h5::File::open_read(path);
  EXPECT_INPUT_ERROR(f.read<double>("x", {-1, 3}), path, "/x", "shape (2, 2), expected (N, 3)");
  EXPECT_INPUT_ERROR(f.read<double>("n"), path, "/n", "type integer");
  EXPECT_INPUT_ERROR(f.read<std::int32_t>("x"), path, "/x", "type floating point");
  EXPECT_INPUT_ERROR(f.read<double>("missing"), path, "/missing", "missing dataset");
  EXPECT_INPUT_ERROR(f.group("nogroup"), path, "/nogroup", "missing group");
  EXPECT_INPUT_ERROR(f.attr_string("nope"), path, "missing attribute 'nope'");
  EXPECT_INPUT_ERROR(h5::File::open_read(tmp / "absent.h5"), "absent.h5", "cannot open");
  {
    std::FILE* txt = std::fopen((tmp / "text.h5").c_str(), "w");
    std::fputs("not hdf5\n", txt);
    std::fclose(txt);
  }
  EXPECT_INPUT_ERROR(h5::File::open_read(tmp / "text.h5"), "text.h5", "not an HDF5 file");
  h5::File w = h5::File::create(tmp / "c.h5");
  EXPECT_INPUT_ERROR(w.write<double>("y", std::vector<double>{1, 2, 3}, {2, 2}), "/y", "do not fill the shape (2, 2)");
}

// Data kept in another file (an external link, raw external storage, a virtual dataset's source)
// is refused before it is opened or read: the other file may be anything (a FIFO blocked the
// reader forever); a dataset declaring a shape it does not store (2.4 GB of a dataset created
// without its data) is refused before a reader allocates it.
TEST(H5, DataOutsideTheFileAndUnstoredShapesAreRefused) {
  test::ScratchDir tmp;
  const std::string other = tmp / "other.h5", path = tmp / "links.h5", fifo = tmp / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  {
    h5::File f = h5::File::create(other);
    f.write<double>("t", std::vector<double>{0, 1, 2}, {3});
  }
  {
    const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    ASSERT_GE(H5Lcreate_external(fifo.c_str(), "/t", f, "linked", H5P_DEFAULT, H5P_DEFAULT), 0);
    const hid_t g = H5Gcreate2(f, "group", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(H5Lcreate_external(other.c_str(), "/t", g, "t", H5P_DEFAULT, H5P_DEFAULT), 0);
    H5Gclose(g);
    const hsize_t n = 3, huge = 300000000, unlimited = H5S_UNLIMITED, chunk = 4096;
    hid_t space = H5Screate_simple(1, &n, nullptr);
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    ASSERT_GE(H5Pset_external(dcpl, fifo.c_str(), 0, H5F_UNLIMITED), 0);
    H5Dclose(H5Dcreate2(f, "external", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT));
    H5Pclose(dcpl);
    dcpl = H5Pcreate(H5P_DATASET_CREATE);
    const hid_t source = H5Screate_simple(1, &n, nullptr);
    ASSERT_GE(H5Pset_virtual(dcpl, space, fifo.c_str(), "/t", source), 0);
    H5Dclose(H5Dcreate2(f, "virtual", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT));
    H5Sclose(source);
    H5Pclose(dcpl);
    H5Sclose(space);
    space = H5Screate_simple(1, &huge, &unlimited);
    dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 1, &chunk);
    H5Dclose(H5Dcreate2(f, "unstored", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT));
    H5Pclose(dcpl);
    H5Sclose(space);
    H5Fclose(f);
  }
  h5::File f = h5::File::open_read(path);
  EXPECT_INPUT_ERROR(f.read<double>("linked"), path, "/linked", "an external link to another file");
  EXPECT_INPUT_ERROR(f.read<double>("group/t"), path, "/group/t", "an external link to another file");
  EXPECT_INPUT_ERROR(f.group("group").read<double>("t"), path, "/group/t", "an external link to another file");
  EXPECT_INPUT_ERROR(f.read<double>("external"), path, "/external", "a dataset whose data is stored in other files");
  EXPECT_INPUT_ERROR(f.read<double>("virtual"), path, "/virtual", "a virtual dataset whose data is stored in other files");
  EXPECT_INPUT_ERROR(f.read<double>("unstored"), path, "/unstored", "shape (300000000,) (2.4 GB of values) but the file "
                                                                    "stores 0 MB of it");
}

// The bound on what a dataset may declare beyond what it stores is on the file's values: 9 million
// uint8 zeros (a long recording's buttons, never pressed) compressed to a few kB read as int64
// (72 MB in memory, past the bound at 8 bytes a value).
TEST(H5, ACompressedNarrowDatasetReadWideIsStored) {
  test::ScratchDir tmp;
  const std::string path = tmp / "buttons.h5";
  const hsize_t n = 9000000, chunk = 65536;
  {
    const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    const hid_t space = H5Screate_simple(1, &n, nullptr), dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 1, &chunk);
    H5Pset_deflate(dcpl, 9);
    const hid_t d = H5Dcreate2(f, "buttons", H5T_STD_U8LE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    const std::vector<std::uint8_t> zeros(n, 0);
    ASSERT_GE(H5Dwrite(d, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, zeros.data()), 0);
    ASSERT_LT(H5Dget_storage_size(d), 72000000 / 1100) << "the test needs a ratio past the bound";
    H5Dclose(d);
    H5Pclose(dcpl);
    H5Sclose(space);
    H5Fclose(f);
  }
  h5::File f = h5::File::open_read(path);
  EXPECT_EQ(f.read<std::int64_t>("buttons").data.size(), n);
}

// A dataset compressed with a filter this HDF5 library lacks (h5py's lzf, written by
// tests/data/io/lzf.h5's maker: h5py, compression='lzf') names the filter and what to do.
TEST(H5, AMissingCompressionFilterIsNamed) {
  const std::string path = std::string(EBH_TEST_DATA_DIR) + "/io/lzf.h5";
  if (H5Zfilter_avail(32000) > 0) GTEST_SKIP() << "this HDF5 library has the lzf filter";
  h5::File f = h5::File::open_read(path);
  EXPECT_INPUT_ERROR(f.read<double>("d"), path, "/d", "compressed with the filter 'lzf' (id 32000)", "gzip");
}

// A file damaged in a copy: compressed data that does not decompress names the rows read and the
// cause; a file cut short names its size against the size it declares. (Each said "cannot read"
// or "cannot open" before.)
TEST(H5, DamagedAndCutShortFilesSayWhatIsWrong) {
  if (H5Zfilter_avail(H5Z_FILTER_DEFLATE) <= 0) GTEST_SKIP() << "this HDF5 library has no deflate filter";
  test::ScratchDir tmp;
  const std::string path = tmp / "damaged.h5";
  std::vector<double> d(40000);
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = std::sin(0.001 * double(i)) + 1e-7 * double(i % 7);
  { h5::File::create(path).write<double>("d", d, {d.size()}, {.compress = true}); }
  const std::uintmax_t size = fs::file_size(path);
  haddr_t offset = 0;
  hsize_t bytes = 0, first_damaged = 0;
  {
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    const hid_t ds = H5Dopen2(f, "d", H5P_DEFAULT);
    const hid_t space = H5Dget_space(ds);
    hsize_t chunks = 0;
    ASSERT_GE(H5Dget_num_chunks(ds, space, &chunks), 0);
    ASSERT_GE(chunks, 2u);  // the second chunk is damaged; the first reads
    hsize_t coord[1];
    unsigned mask = 0;
    ASSERT_GE(H5Dget_chunk_info(ds, space, 1, coord, &mask, &offset, &bytes), 0);
    first_damaged = coord[0];
    H5Sclose(space);
    H5Dclose(ds);
    H5Fclose(f);
  }
  const std::string damaged = tmp / "damaged_copy.h5";
  fs::copy_file(path, damaged);
  {
    std::FILE* fp = std::fopen(damaged.c_str(), "r+b");
    ASSERT_NE(fp, nullptr);
    std::fseek(fp, static_cast<long>(offset + bytes / 2), SEEK_SET);
    const unsigned char junk[16] = {0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff};
    std::fwrite(junk, 1, sizeof junk, fp);
    std::fclose(fp);
  }
  h5::File f = h5::File::open_read(damaged);
  EXPECT_EQ(f.dataset("d").read_rows<double>({-1}, 0, 10).data[9], d[9]);  // the first chunk reads
  EXPECT_INPUT_ERROR(f.read<double>("d"), damaged, "/d: cannot read the dataset: compressed data in it does not decompress",
                     "damaged");
  EXPECT_INPUT_ERROR(f.dataset("d").read_rows<double>({-1}, first_damaged, 10), "/d: cannot read rows " +
                         std::to_string(first_damaged) + ".." + std::to_string(first_damaged + 9) + " of 40000: compressed");

  const std::string cut = tmp / "cut.h5";
  fs::copy_file(path, cut);
  fs::resize_file(cut, size / 2);
  EXPECT_INPUT_ERROR((void)h5::File::open_read(cut), cut, "cannot open HDF5 file: it is cut short (it ends after " +
                                                               std::to_string(size / 2) + " of its " + std::to_string(size) +
                                                               " bytes)");
}

// A file with HDF5's signature and nothing of an HDF5 file after it (said "cannot open HDF5 file"
// before): its header is named as damaged, with its size and HDF5's reason.
TEST(H5, ASignatureWithoutAFileIsADamagedHeader) {
  test::ScratchDir tmp;
  const std::string path = tmp / "signature.h5";
  {
    std::FILE* fp = std::fopen(path.c_str(), "wb");
    ASSERT_NE(fp, nullptr);
    const unsigned char file[108] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};  // then zeros
    ASSERT_EQ(std::fwrite(file, 1, sizeof file, fp), sizeof file);
    std::fclose(fp);
  }
  EXPECT_INPUT_ERROR((void)h5::File::open_read(path), path,
                     ": cannot open HDF5 file: it starts with HDF5's signature but its header (superblock) is damaged "
                     "(108 bytes; HDF5: ",
                     "): a damaged copy, or no HDF5 file");
}

// A checksum that fails (fletcher32, uncompressed data) is said as such, not as data that does
// not decompress.
TEST(H5, AChecksumThatFailsIsNamed) {
  test::ScratchDir tmp;
  const std::string path = tmp / "checked.h5";
  const hsize_t n = 4096, chunk = 1024;
  haddr_t offset = 0;
  {
    const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    const hid_t space = H5Screate_simple(1, &n, nullptr), dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 1, &chunk);
    H5Pset_fletcher32(dcpl);
    const hid_t d = H5Dcreate2(f, "t", H5T_IEEE_F64LE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    const std::vector<double> v(n, 1.5);
    ASSERT_GE(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), 0);
    H5Dflush(d);
    hsize_t coord[1];
    unsigned mask = 0;
    hsize_t bytes = 0;
    ASSERT_GE(H5Dget_chunk_info(d, space, 0, coord, &mask, &offset, &bytes), 0);
    H5Dclose(d);
    H5Pclose(dcpl);
    H5Sclose(space);
    H5Fclose(f);
  }
  {
    std::FILE* fp = std::fopen(path.c_str(), "r+b");
    ASSERT_NE(fp, nullptr);
    std::fseek(fp, static_cast<long>(offset + 8), SEEK_SET);
    const unsigned char junk[4] = {0x12, 0x34, 0x56, 0x78};
    std::fwrite(junk, 1, sizeof junk, fp);
    std::fclose(fp);
  }
  h5::File f = h5::File::open_read(path);
  EXPECT_INPUT_ERROR(f.read<double>("t"), path, "/t: cannot read the dataset: its checksum (fletcher32) does not match the data",
                     "the file is damaged");
}

TEST(H5, AppendableDatasetGrowsByRows) {
  test::ScratchDir tmp;
  const std::string path = tmp / "app.h5";
  {
    h5::File f = h5::File::create(path);
    auto force = f.create_appendable<double>("haptic/force", {3}, 4);
    auto t = f.create_appendable<double>("haptic/t", {}, 4);
    for (int i = 0; i < 10; ++i) {
      std::vector<double> row{double(i), 2.0 * i, -1.0 * i};
      force.append(row);
      double ti = 0.001 * i;
      t.append(std::span<const double>(&ti, 1));
    }
    std::vector<double> two_rows{10, 20, -10, 11, 22, -11};
    force.append(two_rows);
    EXPECT_EQ(force.rows(), 12u);
    EXPECT_INPUT_ERROR(force.append(std::vector<double>{1, 2}), "/haptic/force", "not a multiple of the row size 3");
  }
  h5::File f = h5::File::open_read(path);
  auto force = f.read<double>("haptic/force", {12, 3});
  EXPECT_EQ(force.data[3 * 11 + 1], 22.0);
  EXPECT_EQ(force.data[3 * 5 + 2], -5.0);
  EXPECT_EQ(f.read<double>("haptic/t", {10}).data[9], 0.001 * 9);
}

TEST(Atomic, UncommittedLeavesNoFile) {
  test::ScratchDir tmp;
  const std::string path = tmp / "out.h5";
  {
    h5::AtomicFile out(path);
    out.file().write<double>("x", std::vector<double>{1, 2}, {2});
    EXPECT_TRUE(fs::exists(partial_path_for(path)));
    EXPECT_FALSE(fs::exists(path));
  }  // destroyed uncommitted, as after an exception
  EXPECT_FALSE(fs::exists(path));
  EXPECT_EQ(tmp.entries(), 0u);
}

TEST(Atomic, CommitRenamesIntoPlaceReplacingAnOldFile) {
  test::ScratchDir tmp;
  const std::string path = tmp / "out.h5";
  {
    std::FILE* old = std::fopen(path.c_str(), "w");
    std::fputs("old", old);
    std::fclose(old);
  }
  {
    h5::AtomicFile out(path);
    out.file().write<double>("x", std::vector<double>{1, 2}, {2});
    out.commit();
  }
  EXPECT_EQ(h5::File::open_read(path).read<double>("x").data, (std::vector<double>{1, 2}));
  EXPECT_EQ(tmp.entries(), 1u);
}

// close_and_sync() then publish(): the finished output is read back under its temporary name
// before it replaces the previous file (`ebh replay --render`); another temporary of the same
// kind, which no output of this process writes, stays refused as an input.
TEST(Atomic, FinishedOutputIsReadBeforeItIsPublished) {
  test::ScratchDir tmp;
  const std::string path = tmp / "out.h5";
  h5::AtomicFile(path).commit();  // the previous output, without "x"
  const std::string stranger = tmp / ("other.h5" + std::string(kPartialSuffix));
  std::fclose(std::fopen(stranger.c_str(), "w"));
  {
    h5::AtomicFile out(path);
    out.file().write<double>("x", std::vector<double>{1, 2}, {2});
    out.close_and_sync();
    EXPECT_EQ(h5::File::open_read(out.temp_path()).read<double>("x").data, (std::vector<double>{1, 2}));
    EXPECT_FALSE(h5::File::open_read(path).has("x"));  // the previous output is still in place
    EXPECT_INPUT_ERROR(h5::File::open_read(stranger), "other.h5", "an unfinished output of ebh");
    out.publish();
  }
  EXPECT_EQ(h5::File::open_read(path).read<double>("x").data, (std::vector<double>{1, 2}));
  EXPECT_INPUT_ERROR(h5::File::open_read(path + std::string(kPartialSuffix)), "an unfinished output of ebh");
}

TEST(Atomic, InterruptedCommitWritesNothing) {
  test::ScratchDir tmp;
  const std::string path = tmp / "out.h5";
  {
    h5::AtomicFile out(path);
    out.file().write<double>("x", std::vector<double>{1}, {1});
    std::raise(SIGINT);  // the installed handler only sets the flag
    EXPECT_TRUE(interrupted());
    EXPECT_INPUT_ERROR(out.commit(), "out.h5", "interrupted");
  }
  set_interrupted(false);
  EXPECT_FALSE(fs::exists(path));
  EXPECT_EQ(tmp.entries(), 0u);
}

TEST(Atomic, SecondSignalRemovesTemporaryFilesAndExits) {
  test::ScratchDir tmp;
  const std::string path = tmp / "out.h5";
  pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {  // the child writes, then gets two interrupts without ever polling
    h5::AtomicFile out(path);
    out.file().write<double>("x", std::vector<double>{1}, {1});
    std::raise(SIGINT);
    usleep(200000);  // the same signal again within 0.1 s would be the same interrupt
    std::raise(SIGINT);
    _exit(0);  // not reached: the second signal exits with 128 + SIGINT
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGINT);
  EXPECT_EQ(tmp.entries(), 0u);
}
