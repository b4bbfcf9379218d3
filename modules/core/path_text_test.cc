#include "core/path_text.h"

#include <gtest/gtest.h>

#include "core/fs.h"
#include "core/json.h"
#include "testing/testing.h"

namespace relight {
namespace {

TEST(PathTextTest, ValidUtf8PassesUnchanged) {
  EXPECT_EQ(PathText("Sacr\xC3\xA9 C\xC5\x93ur.jpg"), "Sacr\xC3\xA9 C\xC5\x93ur.jpg");  // "Sacré Cœur.jpg"
  EXPECT_EQ(PathText("\xF0\x9F\x93\xB7 photo"), "\xF0\x9F\x93\xB7 photo");            // 4-byte emoji
  EXPECT_EQ(PathText(""), "");
  EXPECT_TRUE(IsValidUtf8("plain/ascii.txt"));
}

TEST(PathTextTest, InvalidBytesBecomeHexEscapes) {
  // The Latin-1 (CP1252) name of issue 34.
  EXPECT_EQ(PathText("Sacr\xe9 C\x9cur.jpg"), "Sacr\\xE9 C\\x9Cur.jpg");
  EXPECT_FALSE(IsValidUtf8("Sacr\xe9"));
  EXPECT_EQ(PathText("\xC0\xAF"), "\\xC0\\xAF");          // overlong '/'
  EXPECT_EQ(PathText("\xED\xA0\x80"), "\\xED\\xA0\\x80");  // a UTF-16 surrogate
  EXPECT_EQ(PathText("\xF4\x90\x80\x80"), "\\xF4\\x90\\x80\\x80");  // above U+10FFFF
  EXPECT_EQ(PathText("ab\xC3"), "ab\\xC3");                // truncated sequence at the end
  EXPECT_EQ(PathText("\xC3\xA9\xFF\xC3\xA9"), "\xC3\xA9\\xFF\xC3\xA9");
}

TEST(PathTextTest, EveryResultIsAcceptedByJson) {
  // nlohmann/json throws type_error 316 on the raw bytes; never on the text.
  std::string all;
  for (int b = 0; b < 256; ++b) all += static_cast<char>(b);
  EXPECT_THROW(Json(all).dump(), Json::type_error);
  const std::string text = PathText(all);
  EXPECT_TRUE(IsValidUtf8(text));
  EXPECT_NO_THROW(Json(text).dump());
}

TEST(PathTextTest, JsonFilesWithNonUtf8NamesAreWritten) {
  testing::TempDir dir;
  OrderedJson j;
  j["name"] = "Sacr\xe9 C\x9cur.jpg";
  j["photos"] = {{{"Sacr\xe9.jpg", "reason: \xff"}}};
  WriteJsonAtomic(dir / "a.json", j);  // threw type_error 316 before
  const Json back = ReadJsonFile(dir / "a.json");
  EXPECT_EQ(back["name"], "Sacr\\xE9 C\\x9Cur.jpg");
  EXPECT_EQ(back["photos"][0]["Sacr\\xE9.jpg"], "reason: \\xFF");
}

}  // namespace
}  // namespace relight
