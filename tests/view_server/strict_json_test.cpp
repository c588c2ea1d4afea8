#include <gtest/gtest.h>

#include "strict_json.hpp"

namespace ioct::view {
namespace {

std::string refusal(std::string_view text, std::size_t max = 1024) {
  try {
    (void)parse_strict_json(text, max);
  } catch (const BadMessage& e) {
    return e.what();
  }
  return "accepted";
}

TEST(StrictJson, ADuplicatedKeyIsAnErrorNamingIt) {
  EXPECT_EQ(refusal(R"({"cmd":"stop","cmd":"start"})"), "the key 'cmd' appears twice");
  EXPECT_EQ(refusal(R"({"a":{"x":1,"x":2}})"), "the key 'x' appears twice");
  EXPECT_EQ(refusal(R"({"a":{"x":1},"b":{"x":2}})"), "accepted") << "same key, other objects";
  EXPECT_EQ(refusal(R"([{"x":1},{"x":2}])"), "accepted");
}

TEST(StrictJson, SizeDepthAndSyntaxAreChecked) {
  EXPECT_NE(refusal(std::string(2000, ' '), 1024).find("larger than 1024"), std::string::npos);
  EXPECT_NE(refusal(std::string(40, '[') + std::string(40, ']')).find("deeper"), std::string::npos);
  EXPECT_NE(refusal(R"({"a":)").find("not valid JSON at byte"), std::string::npos);
}

TEST(StrictJson, QuotedInputIsPrintableAndShort) {
  EXPECT_EQ(quote_input("ab\x01\n\xff"), std::string("'ab") + "???" + "'");
  EXPECT_EQ(quote_input(std::string(100, 'x'), 5), "'xxxxx...'");
}

}  // namespace
}  // namespace ioct::view
