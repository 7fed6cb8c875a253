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

// Valid as RFC 3629 has it, which JSON parsers require: an overlong form ('/' as e0 80 af), a
// UTF-16 surrogate (ed a0 80) and a code point past U+10FFFF (f4 90 80 80) are not text (they were
// kept, and a --json output holding them was refused by Python's json module); the edges of each
// range are (U+0800 e0 a0 80, U+D7FF ed 9f bf, U+10000 f0 90 80 80, U+10FFFF f4 8f bf bf).
TEST(InputError, OverlongFormsSurrogatesAndCodePointsPastUnicodeAreNotText) {
  EXPECT_EQ(first_invalid_utf8("a\xe0\x80\xaf"), 1u);
  EXPECT_EQ(first_invalid_utf8("s\xed\xa0\x80.h5"), 1u);
  EXPECT_EQ(first_invalid_utf8("\xf0\x80\x80\xaf"), 0u);
  EXPECT_EQ(first_invalid_utf8("\xf4\x90\x80\x80"), 0u);
  EXPECT_EQ(first_invalid_utf8("\xe0\xa0\x80\xed\x9f\xbf\xf0\x90\x80\x80\xf4\x8f\xbf\xbf"), std::string_view::npos);
  EXPECT_STREQ(InputError(std::string("s\xed\xa0\x80.h5")).what(), "s\\xed\\xa0\\x80.h5");
}

// A layout control changes how a line reads without showing: U+2028 breaks it in some viewers,
// U+202E shows "run<U+202E>5h.x" as "runx.h5"; C1 controls are controls. Escaped byte by byte as
// the bytes that are no text are; other non-ASCII text is kept.
TEST(InputError, LayoutControlsAreEscaped) {
  EXPECT_STREQ(InputError("a\xe2\x80\xa8" "b").what(), "a\\xe2\\x80\\xa8b");
  EXPECT_STREQ(InputError("run\xe2\x80\xae" "5h.x").what(), "run\\xe2\\x80\\xae5h.x");
  EXPECT_STREQ(InputError("\xe2\x81\xa6x\xe2\x80\x8f").what(), "\\xe2\\x81\\xa6x\\xe2\\x80\\x8f");
  EXPECT_STREQ(InputError("c1 \xc2\x85 end").what(), "c1 \\xc2\\x85 end");
  EXPECT_STREQ(InputError("\xc2\xa0\xe2\x80\x94\xe2\x80\xa7").what(), "\xc2\xa0\xe2\x80\x94\xe2\x80\xa7");  // kept
  EXPECT_EQ(first_invalid_utf8_byte("ok \xc3\xa9"), "");
  EXPECT_EQ(first_invalid_utf8_byte("caf\xe9"), "0xe9");
}
