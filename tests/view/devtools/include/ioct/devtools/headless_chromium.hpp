// A headless Chromium started for a test: its own throw-away profile, remote debugging on a port
// the browser picks (read from the profile's DevToolsActivePort file), its output in a log file.
// Closing it ends the browser and every process it started (its own process group).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "ioct/devtools/browser_page.hpp"
#include "ioct/devtools/cdp_connection.hpp"

namespace ioct::devtools {

struct ChromiumOptions {
  int window_width = 1400;
  int window_height = 900;
  std::filesystem::path log_file;  // the browser's stdout and stderr; empty: in the profile
  std::chrono::milliseconds start_timeout{30'000};
  // Lets file:// pages import ES modules from file:// (the page modules' tests need no server).
  bool allow_file_access = false;
};

class HeadlessChromium {
 public:
  // $IOCT_CHROMIUM when set, else the first of chromium, chromium-browser, google-chrome on PATH.
  static std::optional<std::filesystem::path> find_executable();

  // Starts the browser and connects to it. Throws std::runtime_error naming what is missing
  // (no browser: "install the Debian package chromium") or what went wrong, with the log's end.
  explicit HeadlessChromium(const ChromiumOptions& options = {});
  ~HeadlessChromium();
  HeadlessChromium(const HeadlessChromium&) = delete;
  HeadlessChromium& operator=(const HeadlessChromium&) = delete;

  // A new tab showing `url` (loaded), its viewport the window's size. Each page has a DevTools
  // connection of its own.
  std::unique_ptr<BrowserPage> open_page(
      const std::string& url,
      std::chrono::milliseconds timeout = std::chrono::milliseconds(20'000));
  void close_page(const BrowserPage& page);

  unsigned short port() const noexcept { return port_; }
  pid_t pid() const noexcept { return pid_; }
  const std::filesystem::path& log_file() const noexcept { return log_file_; }
  // The last `bytes` of the browser's log, for failure messages.
  std::string log_tail(std::size_t bytes = 2000) const;

 private:
  void stop() noexcept;

  int viewport_width_;
  int viewport_height_;
  std::filesystem::path profile_;
  std::filesystem::path log_file_;
  pid_t pid_ = -1;
  unsigned short port_ = 0;
  std::unique_ptr<CdpConnection> browser_;
};

}  // namespace ioct::devtools
