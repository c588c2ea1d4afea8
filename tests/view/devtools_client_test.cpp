// The DevTools client itself, on pages that need no server: Chromium starts headless, a page
// loads, JavaScript runs (promises awaited, exceptions reported with their message), and a
// screenshot comes back as a PNG of the window's size.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "ioct/devtools/base64.hpp"
#include "ioct/devtools/headless_chromium.hpp"

namespace ioct::devtools {
namespace {

using namespace std::chrono_literals;

std::uint32_t big_endian_u32(const std::vector<std::uint8_t>& bytes, std::size_t at) {
  return (std::uint32_t{bytes.at(at)} << 24) | (std::uint32_t{bytes.at(at + 1)} << 16) |
         (std::uint32_t{bytes.at(at + 2)} << 8) | std::uint32_t{bytes.at(at + 3)};
}

TEST(Base64, DecodesWithAndWithoutPadding) {
  EXPECT_EQ(decode_base64("aW9jdA=="), (std::vector<std::uint8_t>{'i', 'o', 'c', 't'}));
  EXPECT_EQ(decode_base64("aW9j"), (std::vector<std::uint8_t>{'i', 'o', 'c'}));
  EXPECT_EQ(decode_base64("/+8="), (std::vector<std::uint8_t>{0xFF, 0xEF}));
  EXPECT_THROW(decode_base64("a*b"), std::invalid_argument);
}

class DevToolsClient : public ::testing::Test {
 protected:
  void SetUp() override {
    // Chromium is part of the project's set-up: without it this is a failure, not a skip.
    ASSERT_TRUE(HeadlessChromium::find_executable().has_value())
        << "no Chromium: install the Debian package chromium (tools/setup.sh does)";
    ChromiumOptions options;
    options.window_width = 640;
    options.window_height = 480;
    browser_ = std::make_unique<HeadlessChromium>(options);
  }

  std::unique_ptr<HeadlessChromium> browser_;
};

TEST_F(DevToolsClient, LoadsAPageAndEvaluatesItsJavaScript) {
  auto page = browser_->open_page("data:text/html,<title>ioct</title><p id=p>four</p>");
  EXPECT_EQ(page->evaluate("document.title", 5s), "ioct");
  EXPECT_EQ(page->evaluate("document.getElementById('p').textContent.length", 5s), 4);
  EXPECT_EQ(page->evaluate("({a: [1, 2], b: 'x'})", 5s),
            (nlohmann::json{{"a", {1, 2}}, {"b", "x"}}));
  EXPECT_TRUE(page->evaluate("undefined", 5s).is_null());
}

TEST_F(DevToolsClient, AwaitsPromisesAndWaitsForConditions) {
  auto page = browser_->open_page("data:text/html,<p>wait</p>");
  EXPECT_EQ(page->evaluate("new Promise(r => setTimeout(() => r(42), 100))", 5s), 42);
  page->evaluate("setTimeout(() => { window.ready = 'yes'; }, 200); 0", 5s);
  nlohmann::json last;
  EXPECT_EQ(page->wait_until("window.ready", 5s, &last), nlohmann::json("yes"));
  EXPECT_FALSE(page->wait_until("window.never", 300ms, &last).has_value());
  EXPECT_TRUE(last.is_null());
}

TEST_F(DevToolsClient, ReportsThePagesExceptionsWithTheirMessage) {
  auto page = browser_->open_page("data:text/html,<p>throw</p>");
  try {
    page->evaluate("throw new Error('the lens is fogged')", 5s);
    FAIL() << "the exception did not reach the test";
  } catch (const JavaScriptError& e) {
    EXPECT_NE(std::string(e.what()).find("the lens is fogged"), std::string::npos) << e.what();
  }
  EXPECT_THROW(page->evaluate("Promise.reject(new Error('rejected'))", 5s), JavaScriptError);
  page->evaluate("setTimeout(() => { throw new Error('later'); }, 0); 0", 5s);
  page->evaluate("new Promise(r => setTimeout(r, 100))", 5s);
  const std::vector<std::string> errors = page->take_page_errors();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("later"), std::string::npos) << errors[0];
}

TEST_F(DevToolsClient, CapturesAScreenshotOfTheWindowsSize) {
  auto page = browser_->open_page(
      "data:text/html,<body style='margin:0;background:rgb(200,30,40)'></body>");
  const std::vector<std::uint8_t> png = page->screenshot_png(10s);
  ASSERT_GT(png.size(), 24u);
  const std::vector<std::uint8_t> signature{0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  EXPECT_TRUE(std::equal(signature.begin(), signature.end(), png.begin()));
  EXPECT_EQ(big_endian_u32(png, 16), 640u) << "IHDR width";
  EXPECT_EQ(big_endian_u32(png, 20), 480u) << "IHDR height";

  const std::filesystem::path saved =
      std::filesystem::path(IOCT_VIEW_TEST_OUTPUT_DIR) / "devtools-client-red-page.png";
  const std::uintmax_t written = page->save_screenshot(saved, 10s);
  EXPECT_EQ(written, std::filesystem::file_size(saved));
}

TEST_F(DevToolsClient, OpensSeveralPagesEachWithItsOwnConnection) {
  auto first = browser_->open_page("data:text/html,<title>one</title>");
  auto second = browser_->open_page("data:text/html,<title>two</title>");
  EXPECT_EQ(first->evaluate("document.title", 5s), "one");
  EXPECT_EQ(second->evaluate("document.title", 5s), "two");
  browser_->close_page(*second);
  EXPECT_EQ(first->evaluate("1 + 1", 5s), 2);
}

}  // namespace
}  // namespace ioct::devtools
