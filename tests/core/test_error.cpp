// InputError (lib/core/error.hpp): messages quote file content, which may be binary; what() is
// always one printable line.
#include <gtest/gtest.h>

#include <string>

#include "core/error.hpp"

using namespace ebh;

TEST(InputError, EscapesBytesATerminalWouldNotShowAsText) {
  const std::string header("\x89HDF\r\n\x1a\n\0\x01", 10);
  const InputError e("log.txt:1: unknown column '" + header + "'");
  EXPECT_STREQ(e.what(), "log.txt:1: unknown column '\\x89HDF\\x0d\\x0a\\x1a\\x0a\\x00\\x01'");
}

TEST(InputError, KeepsValidUtf8) {
  EXPECT_STREQ(InputError("données/µm.csv: no samples").what(), "données/µm.csv: no samples");
  // A lone continuation byte and a truncated sequence are not text.
  EXPECT_STREQ(InputError(std::string("a\x80z\xc3")).what(), "a\\x80z\\xc3");
}
