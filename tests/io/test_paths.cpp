// lib/io/paths.hpp: an output never replaces an input (same file through any name, link or hard
// link), and an input is a readable file, never a folder or an unfinished output.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/file_names.hpp"
#include "io/atomic.hpp"
#include "io/paths.hpp"
#include "io_test_util.hpp"

using namespace ebh;
namespace fs = std::filesystem;

TEST(Paths, SameFileThroughAnyNameOrLink) {
  test::ScratchDir tmp;
  fs::create_directories(tmp / "sub");
  std::ofstream(tmp / "rec.h5") << "recording";
  std::ofstream(tmp / "other.h5") << "other";
  fs::create_symlink(tmp / "rec.h5", tmp / "link.h5");
  fs::create_hard_link(tmp / "rec.h5", tmp / "hard.h5");
  EXPECT_TRUE(same_file(tmp / "rec.h5", tmp / "sub/../rec.h5"));
  EXPECT_TRUE(same_file(tmp / "rec.h5", tmp / "link.h5"));
  EXPECT_TRUE(same_file(tmp / "rec.h5", tmp / "hard.h5"));
  EXPECT_FALSE(same_file(tmp / "rec.h5", tmp / "other.h5"));
  // A file that does not exist yet is compared by its canonical path.
  EXPECT_TRUE(same_file(tmp / "new.h5", tmp / "sub/../new.h5"));
  EXPECT_FALSE(same_file(tmp / "new.h5", tmp / "rec.h5"));
}

TEST(Paths, OutputOverAnInputIsRefusedNamingBoth) {
  test::ScratchDir tmp;
  std::ofstream(tmp / "rec.h5") << "recording";
  fs::create_symlink(tmp / "rec.h5", tmp / "link.h5");
  const std::vector<RoleFile> inputs{{tmp / "scene.yaml", "the scene file"}, {tmp / "rec.h5", "the recording"}};
  EXPECT_INPUT_ERROR(check_outputs({{tmp / "link.h5", "the replay output"}}, inputs), "link.h5: the output would replace the recording ",
                     "rec.h5, an input of this command");
  EXPECT_INPUT_ERROR(check_outputs({{tmp / "a.h5", "the output"}, {tmp / "a.h5", "its index"}}, inputs),
                     "a.h5: is both the output and its index");
  check_outputs({{tmp / "out.h5", "the replay output"}, {"", "nothing"}}, inputs);  // no error
  std::ofstream(tmp / "afile") << "x";
  EXPECT_INPUT_ERROR(check_outputs({{tmp / "afile/out.h5", "the output"}}, inputs),
                     "afile/out.h5: cannot create the output: Not a directory");
}

// A folder that cannot be written is said as such before any work (a replay's free-space check
// said "0 bytes free: free space" for /proc and /sys): the output's temporary is tried there.
TEST(Paths, AnOutputOnAVirtualFileSystemSaysWhy) {
  struct statvfs proc {};
  if (::statvfs("/proc", &proc) != 0 || proc.f_blocks != 0) GTEST_SKIP() << "no procfs at /proc";
  EXPECT_INPUT_ERROR(check_outputs({{"/proc/run.h5", "the output"}}, {}),
                     "/proc/run.h5: cannot create the output: No such file or directory (/proc is on a virtual file "
                     "system, which holds no files: choose another folder)");
  EXPECT_INPUT_ERROR(check_outputs({{"/proc/new/run.h5", "the output"}}, {}), "/proc/new/run.h5: cannot create the output: ");
  EXPECT_FALSE(free_bytes_for("/proc/run.h5").has_value());  // not "0 bytes free"
}
TEST(Paths, AnOutputInAReadOnlyFolderSaysWhy) {
  if (::geteuid() == 0) GTEST_SKIP() << "root may write in a read-only folder";
  test::ScratchDir tmp;
  fs::create_directories(tmp.dir / "ro");
  ASSERT_EQ(::chmod((tmp.dir / "ro").c_str(), 0555), 0);
  EXPECT_INPUT_ERROR(check_outputs({{tmp / "ro/run.h5", "the output"}}, {}), "ro/run.h5: cannot create the output: Permission denied");
  EXPECT_INPUT_ERROR(check_outputs({{tmp / "ro/new/run.h5", "the output"}}, {}), "ro/new/run.h5: cannot create the output: Permission denied");
  ::chmod((tmp.dir / "ro").c_str(), 0755);
}

// An output named by a link to nothing is checked where the link leads: its folder must exist, and
// a loop of links is refused, before any work; the check leaves no file behind.
TEST(Paths, AnOutputThatIsALinkToNothingIsCheckedWhereItLeads) {
  test::ScratchDir tmp;
  fs::create_directories(tmp.dir / "store");
  fs::create_symlink("store/run.h5", tmp / "run.h5");
  fs::create_symlink("nowhere/run.h5", tmp / "dangling.h5");
  fs::create_symlink("b.h5", tmp / "a.h5");
  fs::create_symlink("a.h5", tmp / "b.h5");
  check_outputs({{tmp / "run.h5", "the output"}}, {});  // no error
  EXPECT_EQ(output_target(tmp / "run.h5"), tmp / "store/run.h5");
  EXPECT_INPUT_ERROR(check_outputs({{tmp / "dangling.h5", "the output"}}, {}),
                     "dangling.h5: cannot create the output: a link to nowhere/run.h5, whose folder ");
  EXPECT_INPUT_ERROR(check_outputs({{tmp / "a.h5", "the output"}}, {}), "a.h5: cannot create the output: a link to b.h5");
  EXPECT_EQ(tmp.entries(), 5u);
  EXPECT_TRUE(fs::is_empty(tmp.dir / "store"));
}

// A link to nothing is the file it would create: the same file as the name it leads to. Two
// outputs of one command where one is such a link naming the other were both written, the second
// over the first, or failed after the work on their one temporary: refused before any work.
TEST(Paths, ALinkToNothingIsTheFileItWouldCreate) {
  test::ScratchDir tmp;
  fs::create_directories(tmp.dir / "store");
  fs::create_symlink("a.yaml", tmp / "a.msh");
  fs::create_symlink("store/new.yaml", tmp / "new.yaml");
  fs::create_symlink("new.yaml", tmp / "chain.yaml");
  fs::create_symlink("loop.yaml", tmp / "loop.yaml");
  EXPECT_TRUE(same_file(tmp / "a.msh", tmp / "a.yaml"));
  EXPECT_TRUE(same_file(tmp / "new.yaml", tmp / "store/new.yaml"));
  EXPECT_TRUE(same_file(tmp / "chain.yaml", tmp / "store/../store/new.yaml"));
  EXPECT_FALSE(same_file(tmp / "new.yaml", tmp / "store/other.yaml"));
  EXPECT_FALSE(same_file(tmp / "a.msh", tmp / "new.yaml"));
  EXPECT_FALSE(same_file(tmp / "loop.yaml", tmp / "a.yaml"));
  EXPECT_EQ(link_end(tmp / "chain.yaml"), tmp / "store/new.yaml");
  EXPECT_EQ(link_end(tmp / "a.yaml"), tmp / "a.yaml");
  EXPECT_EQ(link_end(tmp / "loop.yaml"), std::nullopt);
  EXPECT_INPUT_ERROR(check_outputs({{tmp / "a.yaml", "the refined scene"}, {tmp / "a.msh", "the refined mesh"}}, {}),
                     "a.msh (a link to a.yaml): is both the refined scene ", "a.yaml and the refined mesh; choose another");
  EXPECT_INPUT_ERROR(check_outputs({{tmp / "chain.yaml", "the output"}, {tmp / "store/new.yaml", "its index"}}, {}),
                     "store/new.yaml: is both the output ", "chain.yaml (a link to new.yaml) and its index");
  check_outputs({{tmp / "new.yaml", "the output"}, {tmp / "store/new.msh", "its mesh"}}, {});  // no error
  EXPECT_EQ(tmp.entries(), 5u);
  EXPECT_TRUE(fs::is_empty(tmp.dir / "store"));
}

// A file written beside an output (a scene's mesh) goes beside the file the output really is, a
// link's target, named after it: the output names it by its file name, from its own folder.
TEST(Paths, ACompanionGoesBesideTheFileTheOutputIs) {
  test::ScratchDir tmp;
  fs::create_directories(tmp.dir / "store");
  std::ofstream(tmp / "store/old.yaml") << "name: old\n";
  fs::create_symlink("store/new.yaml", tmp / "new.yaml");
  fs::create_symlink("store/other.yaml", tmp / "named.yaml");
  fs::create_symlink("store/old.yaml", tmp / "old.yaml");
  EXPECT_EQ(companion_output(tmp / "plain.yaml", ".msh"), tmp / "plain.msh");
  EXPECT_EQ(companion_output(tmp / "new.yaml", ".msh"), tmp / "store/new.msh");
  EXPECT_EQ(companion_output(tmp / "named.yaml", ".obj"), tmp / "store/other.obj");
  EXPECT_EQ(fs::path(companion_output(tmp / "old.yaml", ".msh")), fs::canonical(tmp.dir / "store") / "old.msh");
  fs::create_symlink("nowhere/gone.yaml", tmp / "gone.yaml");
  EXPECT_INPUT_ERROR(companion_output(tmp / "gone.yaml", ".msh"), "gone.yaml: cannot create the output: a link to nowhere/gone.yaml, whose folder");
}

// The rename into place fails on a name the file system cannot hold: said before any work, for the
// output's own name and for a folder it would make.
TEST(Paths, ANameLongerThanTheFileSystemAllowsIsRefusedBeforeAnyWork) {
  test::ScratchDir tmp;
  const long name_max = ::pathconf(tmp.dir.c_str(), _PC_NAME_MAX);
  ASSERT_GT(name_max, 3);
  const std::string longest = std::string(name_max - 3, 'a') + ".h5", too_long = "a" + longest;
  check_outputs({{tmp / longest, "the output"}}, {});  // no error
  EXPECT_INPUT_ERROR(check_outputs({{tmp / too_long, "the output"}}, {}),
                     too_long + ": cannot create the output: File name too long (a name of " +
                         std::to_string(name_max + 1) + " bytes; this file system allows " + std::to_string(name_max) + ")");
  EXPECT_INPUT_ERROR(check_outputs({{tmp / (too_long + "/run.h5"), "the output"}}, {}), "File name too long");
  EXPECT_INPUT_ERROR(AtomicOutput(tmp / too_long), "cannot create the output: File name too long");
  EXPECT_FALSE(fs::exists(partial_path_for(tmp / too_long)));
}

// The name created through a link is its target's: a short link to a name too long was let
// through (the link's own name fits), and refused only as a link that cannot be followed.
TEST(Paths, ANameTooLongAtTheEndOfALinkIsRefusedByItsLength) {
  test::ScratchDir tmp;
  fs::create_directories(tmp.dir / "store");
  const long name_max = ::pathconf((tmp.dir / "store").c_str(), _PC_NAME_MAX);
  ASSERT_GT(name_max, 3);
  const std::string too_long = std::string(name_max - 2, 'a') + ".h5";
  fs::create_symlink("store/" + too_long, tmp / "short.h5");
  const std::string why = "short.h5: cannot create the output: File name too long (a name of " +
                          std::to_string(name_max + 1) + " bytes at the end of its link, ";
  const std::string allows = "; this file system allows " + std::to_string(name_max) + ")";
  EXPECT_INPUT_ERROR(check_name_length(tmp / "short.h5"), why, allows);
  EXPECT_INPUT_ERROR(check_outputs({{tmp / "short.h5", "the output"}}, {}), why, allows);
  EXPECT_INPUT_ERROR(AtomicOutput(tmp / "short.h5"), why);
  // A link of the longest name leading to a short one is created as that short name.
  const std::string longest = std::string(name_max - 3, 'b') + ".h5";
  fs::create_symlink("store/run.h5", tmp / longest);
  check_name_length(tmp / longest);  // no error
  check_outputs({{tmp / longest, "the output"}}, {});
  EXPECT_EQ(tmp.entries(), 3u);
  EXPECT_TRUE(fs::is_empty(tmp.dir / "store"));
}

// A control character in an output's name would split every line that names it: refused, the
// message on one line.
TEST(Paths, AnOutputNamedWithAControlCharacterIsRefused) {
  test::ScratchDir tmp;
  for (const std::string name : {"a\nb.h5", "tab\there.h5", "esc\x1b[31m.h5"}) {
    EXPECT_INPUT_ERROR(check_outputs({{tmp / name, "the output"}}, {}), "the output's name holds a control character");
    try {
      check_outputs({{tmp / name, "the output"}}, {});
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  }
  check_outputs({{tmp / "caf\xc3\xa9 run.h5", "the output"}}, {});  // UTF-8 and blanks are names
  EXPECT_INPUT_ERROR(check_outputs({{"-", "the output"}}, {}), "-: an output is a file (standard output is not one here)");
}

TEST(Paths, InputMustBeAReadableFile) {
  test::ScratchDir tmp;
  EXPECT_INPUT_ERROR(check_input_file(tmp / "absent.csv"), "absent.csv: cannot open: No such file or directory");
  EXPECT_INPUT_ERROR(check_input_file(tmp.dir.string()), ": is a folder, not a file");
  const std::string partial = partial_path_for(tmp / "run.h5");
  std::ofstream(partial) << "half a file";
  EXPECT_INPUT_ERROR(check_input_file(partial), "an unfinished output of ebh");
  // A named pipe's open waits for a writer (an import hung on one), and a second read of a pipe
  // finds nothing; a device is no file either.
  const std::string fifo = tmp / "log.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_INPUT_ERROR(check_input_file(fifo), "log.fifo: is a pipe, not a file: save what it gives to a file");
  EXPECT_INPUT_ERROR(check_input_file("/dev/null"), "/dev/null: is a device or a socket, not a file");
}

// The temporary folder: $TMPDIR, /tmp where it is unset or empty, and one line naming TMPDIR where it
// is no folder (filesystem's temp_directory_path made that an internal error); a TemporaryFolder
// is made under it and goes with what it holds.
TEST(Paths, TheTemporaryFolderIsTmpdirOrTmpAndSaidWhenMissing) {
  const char* given = std::getenv("TMPDIR");
  const std::string saved = given ? given : "";
  const fs::path dir = fs::temp_directory_path() / ("ebh_test_tmpdir_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  ::setenv("TMPDIR", dir.c_str(), 1);
  EXPECT_EQ(temporary_directory(), dir);
  fs::path made;
  {
    const TemporaryFolder folder("ebh_test_", "the test's folder");
    made = folder.path();
    EXPECT_EQ(made.parent_path(), dir);
    EXPECT_EQ(made.filename().string().rfind("ebh_test_", 0), 0u);
    std::ofstream(made / "f") << "x";
  }
  EXPECT_FALSE(fs::exists(made));
  ::setenv("TMPDIR", "", 1);
  EXPECT_EQ(temporary_directory(), fs::path("/tmp"));
  ::setenv("TMPDIR", (dir / "missing").c_str(), 1);
  EXPECT_INPUT_ERROR(temporary_directory(), "TMPDIR '" + (dir / "missing").string() + "': no such folder");
  EXPECT_INPUT_ERROR(TemporaryFolder("ebh_test_", "the test's folder"), "TMPDIR '", "': no such folder");
  if (given) ::setenv("TMPDIR", saved.c_str(), 1);
  else ::unsetenv("TMPDIR");
  fs::remove_all(dir);
}
