// File names as the commands take and make them (lib/core/file_names.hpp).
#include <gtest/gtest.h>

#include <string>

#include "core/file_names.hpp"

using namespace ebh;

TEST(FileNames, ExtensionsCompareInLowerCase) {
  EXPECT_EQ(lower_extension("a/B.STL"), ".stl");
  EXPECT_EQ(lower_extension("a/b"), "");
  EXPECT_TRUE(has_yaml_extension("scene.YML"));
  EXPECT_FALSE(has_yaml_extension("scene.msh"));
}

// A name read from a file that would start a file's name in a folder: one that leaves the folder
// ('../../x', an absolute path), hides the file or splits the lines that name it is refused, saying why.
TEST(FileNames, ANameThatIsNoFileNameSaysWhy) {
  for (const char* ok : {"tube", "cholecystectomy_hook", "tube.v2", "données", "a b"}) EXPECT_EQ(file_name_problem(ok), "") << ok;
  EXPECT_EQ(file_name_problem(""), "is empty");
  for (const char* path : {"../../x", "/tmp/abs", "a/b", "x/"})
    EXPECT_EQ(file_name_problem(path), "holds a '/' (a path, not a file's name)") << path;
  for (const char* dot : {"..", ".", ".hidden"})
    EXPECT_EQ(file_name_problem(dot), "starts with a '.' (a folder above, or a hidden file)") << dot;
  for (const char* ctrl : {"nl\nname", "tab\t", "esc\x1b[31m", "del\x7f"})
    EXPECT_EQ(file_name_problem(ctrl), "holds a control character (a line break, a tab?)");
}
