// One tab of a headless Chromium, driven over its own DevTools connection: navigate, evaluate
// JavaScript (promises awaited, results by value), wait for a condition, take a screenshot.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ioct/devtools/cdp_connection.hpp"

namespace ioct::devtools {

// The page's JavaScript threw (or a promise it returned rejected).
class JavaScriptError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class BrowserPage {
 public:
  BrowserPage(std::unique_ptr<CdpConnection> connection, std::string target_id);

  const std::string& target_id() const noexcept { return target_id_; }

  // Loads `url` and waits for its load event; throws CdpError when it fails or takes too long.
  void navigate(const std::string& url, std::chrono::milliseconds timeout);

  // The value of `expression` (awaited when it is a promise), as JSON; undefined is null.
  // Throws JavaScriptError with the page's message when it throws.
  nlohmann::json evaluate(const std::string& expression, std::chrono::milliseconds timeout);

  // Evaluates `expression` every `poll` until its value is truthy; returns that value, or
  // nullopt when `timeout` passes first (the last value is then in `last`, when given).
  std::optional<nlohmann::json> wait_until(
      const std::string& expression, std::chrono::milliseconds timeout,
      nlohmann::json* last = nullptr,
      std::chrono::milliseconds poll = std::chrono::milliseconds(50));

  // The viewport as PNG bytes.
  std::vector<std::uint8_t> screenshot_png(std::chrono::milliseconds timeout);
  // Writes the screenshot to `path` (folders created) and returns its size in bytes.
  std::uintmax_t save_screenshot(const std::filesystem::path& path,
                                 std::chrono::milliseconds timeout);

  // Uncaught exceptions and console errors the page reported so far, one line each (consumed).
  std::vector<std::string> take_page_errors();

  CdpConnection& connection() noexcept { return *connection_; }

 private:
  std::unique_ptr<CdpConnection> connection_;
  std::string target_id_;
};

}  // namespace ioct::devtools
