// The --json writer (io/json.hpp): its text is valid UTF-8 JSON whatever its strings hold.
#include <gtest/gtest.h>

#include <string>

#include "core/error.hpp"
#include "io/json.hpp"

using namespace ebh;

// A name that is not UTF-8 (a Latin-1 file name, a scene attribute stored as raw bytes) was copied
// into the JSON byte for byte, which every JSON parser refuses (RFC 8259 requires UTF-8). Each such
// byte is the text \xNN, as the text outputs show it (escape_unprintable); valid UTF-8 is kept.
TEST(Json, BytesThatAreNotUtf8AreWrittenAsTheTextOutputShowsThem) {
  Json j = Json::object();
  j.set("file", "bad\xff.h5");
  j.set("scene", std::string("tube\xff\xfe"));
  j.set("k\xe9y", "caf\xc3\xa9 \xe2\x80\xa8 \xf0\x9f\x98\x80");  // a Latin-1 key; U+00E9, U+2028, U+1F600 kept
  j.set("cut", "ab\xe2\x80");                                       // a sequence cut short at the end
  j.set("lone", "\x80x\xc3(");                                      // a lone continuation, a lead without one
  const std::string out = j.dump(-1);
  EXPECT_EQ(out,
            "{\"file\": \"bad\\\\xff.h5\", \"scene\": \"tube\\\\xff\\\\xfe\", "
            "\"k\\\\xe9y\": \"caf\xc3\xa9 \xe2\x80\xa8 \xf0\x9f\x98\x80\", \"cut\": \"ab\\\\xe2\\\\x80\", "
            "\"lone\": \"\\\\x80x\\\\xc3(\"}");
  EXPECT_EQ(first_invalid_utf8(out), std::string::npos) << out;
  // Parsed, the JSON's scene is tube\xff\xfe: what the text output prints for the same bytes.
  EXPECT_EQ(escape_unprintable("tube\xff\xfe"), "tube\\xff\\xfe");
}

TEST(Json, ControlCharactersAndQuotesAreEscaped) {
  Json j = Json::array();
  j.push("a\"b\\c\nd\te\rf\x01g\x7f");
  EXPECT_EQ(j.dump(-1), "[\"a\\\"b\\\\c\\nd\\te\\rf\\u0001g\x7f\"]");
}
