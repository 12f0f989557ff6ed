#include "protocol/wire/access_token.h"

#include <gtest/gtest.h>

#include <vector>

namespace loam::wire {
namespace {

TEST(AccessToken, ParsesEitherCaseAndFormatsLowercase) {
  auto t = parse_access_token("00112233445566778899AABBccddeeff");
  ASSERT_TRUE(t.ok()) << t.error().describe();
  EXPECT_EQ((*t)[0], 0x00);
  EXPECT_EQ((*t)[10], 0xaa);
  EXPECT_EQ((*t)[15], 0xff);
  EXPECT_EQ(format_access_token(*t), "00112233445566778899aabbccddeeff");
}

TEST(AccessToken, RejectsWrongLengthNamingTheField) {
  for (const char* bad :
       {"", "0011", "00112233445566778899aabbccddeeff00", " 0112233445566778899aabbccddeeff"}) {
    auto t = parse_access_token(bad, "--editor-token");
    ASSERT_FALSE(t.ok()) << bad;
    EXPECT_EQ(t.error().code, ErrorCode::kInvalidArgument);
    EXPECT_EQ(t.error().field, "--editor-token");
  }
}

TEST(AccessToken, RejectsNonHexCharactersNamingTheirPosition) {
  // sscanf("%2x") would have read "0x" and "+1" as numbers; a strict parser must not.
  for (const char* bad : {"0x112233445566778899aabbccddeeff", "+1112233445566778899aabbccddeeff",
                          "00112233445566778899aabbccddeefg", "0011223344556677 899aabbccddeeff"}) {
    auto t = parse_access_token(bad);
    ASSERT_FALSE(t.ok()) << bad;
    EXPECT_NE(t.error().message.find("character"), std::string::npos) << t.error().message;
  }
  auto t = parse_access_token("00112233445566778899aabbccddeefg");
  EXPECT_NE(t.error().message.find("character 32"), std::string::npos) << t.error().message;
}

TEST(AccessToken, EqualityLooksAtEveryByte) {
  const AccessToken a = *parse_access_token("00112233445566778899aabbccddeeff");
  AccessToken b = a;
  EXPECT_TRUE(access_tokens_equal(a, b));
  for (size_t i = 0; i < b.size(); ++i) {
    b = a;
    b[i] ^= 0x80;
    EXPECT_FALSE(access_tokens_equal(a, b)) << i;
  }
}

constexpr const char* kEditor = "00112233445566778899aabbccddeeff";
constexpr const char* kViewer = "ffeeddccbbaa99887766554433221100";

TEST(AccessTokenLines, TokensFileTakesRolesCommentsAndBlankLines) {
  AccessTokenList t;
  const std::string text =
      std::string("# who may join\n\neditor ") + kEditor + "\r\n  viewer\t" + kViewer + "  \n";
  ASSERT_TRUE(parse_token_lines(text, "tokens", t).ok());
  ASSERT_EQ(t.editors.size(), 1u);
  ASSERT_EQ(t.viewers.size(), 1u);
  EXPECT_EQ(t.editors[0], *parse_access_token(kEditor));
  EXPECT_EQ(t.viewers[0], *parse_access_token(kViewer));
}

TEST(AccessTokenLines, TokensFileErrorsNameFileAndLine) {
  struct Case {
    std::string text, field, says;
  };
  for (const Case& c : std::vector<Case>{
           {std::string("editor ") + kEditor + "\nadmin " + kViewer + "\n", "tokens:2", "unknown role"},
           {"# ok\neditor\n", "tokens:2", "expected"},
           {"viewer 1234\n", "tokens:1", "32 hex digits"},
       }) {
    AccessTokenList t;
    const Status st = parse_token_lines(c.text, "tokens", t);
    ASSERT_FALSE(st.ok()) << c.text;
    EXPECT_EQ(st.error().field, c.field);
    EXPECT_NE(st.error().message.find(c.says), std::string::npos) << st.error().message;
  }
}

}  // namespace
}  // namespace loam::wire
