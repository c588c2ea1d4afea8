#include "ioct/devtools/headless_chromium.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

extern char** environ;

namespace ioct::devtools {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

std::optional<std::filesystem::path> on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "/usr/bin:/bin");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const std::filesystem::path candidate = std::filesystem::path(dir) / name;
    if (!dir.empty() && ::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return std::nullopt;
}

std::filesystem::path make_profile_dir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "ioct-chromium-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) {
    throw std::runtime_error("cannot make a Chromium profile folder in " +
                             std::filesystem::temp_directory_path().string());
  }
  return pattern;
}

// DevToolsActivePort: the port on the first line, the browser's WebSocket path on the second.
std::optional<std::pair<unsigned short, std::string>> read_active_port(
    const std::filesystem::path& profile) {
  std::ifstream in(profile / "DevToolsActivePort");
  std::string port_line;
  std::string path_line;
  if (!std::getline(in, port_line) || !std::getline(in, path_line) || path_line.empty()) {
    return std::nullopt;
  }
  return std::make_pair(static_cast<unsigned short>(std::stoul(port_line)), path_line);
}

}  // namespace

std::optional<std::filesystem::path> HeadlessChromium::find_executable() {
  if (const char* chosen = std::getenv("IOCT_CHROMIUM"); chosen && *chosen) {
    if (::access(chosen, X_OK) == 0) return std::filesystem::path(chosen);
    return on_path(chosen);
  }
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    if (auto found = on_path(name)) return found;
  }
  return std::nullopt;
}

HeadlessChromium::HeadlessChromium(const ChromiumOptions& options)
    : viewport_width_(options.window_width), viewport_height_(options.window_height) {
  const std::optional<std::filesystem::path> executable = find_executable();
  if (!executable) {
    throw std::runtime_error(
        "no Chromium found (chromium, chromium-browser or google-chrome on PATH, or "
        "$IOCT_CHROMIUM): install the Debian package chromium (tools/setup.sh does)");
  }
  profile_ = make_profile_dir();
  log_file_ = options.log_file.empty() ? profile_ / "chromium.log" : options.log_file;
  if (log_file_.has_parent_path()) std::filesystem::create_directories(log_file_.parent_path());

  std::vector<std::string> args = {
      executable->string(), "--headless=new", "--remote-debugging-port=0",
      "--user-data-dir=" + profile_.string(),
      "--no-sandbox",  // CI runs as root, where Chromium's sandbox refuses to start
      "--no-first-run", "--no-default-browser-check", "--disable-extensions",
      "--disable-background-networking", "--disable-dev-shm-usage", "--disable-gpu",
      // A hidden headless tab must keep its timers and animation frames running: the pages'
      // staleness checks run on them.
      "--disable-background-timer-throttling", "--disable-renderer-backgrounding",
      "--disable-backgrounding-occluded-windows", "--hide-scrollbars", "--mute-audio",
      "--window-size=" + std::to_string(options.window_width) + "," +
          std::to_string(options.window_height),
      "about:blank"};
  if (options.allow_file_access) {
    args.insert(args.end() - 1, "--allow-file-access-from-files");
  }
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  ::posix_spawn_file_actions_init(&actions);
  ::posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_file_.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ::posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  ::posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawnattr_t attributes;
  ::posix_spawnattr_init(&attributes);
  // A process group of its own, so stop() ends the renderers and helpers too.
  ::posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  ::posix_spawnattr_setpgroup(&attributes, 0);
  const int rc = ::posix_spawn(&pid_, argv[0], &actions, &attributes, argv.data(), environ);
  ::posix_spawn_file_actions_destroy(&actions);
  ::posix_spawnattr_destroy(&attributes);
  if (rc != 0) {
    pid_ = -1;
    std::filesystem::remove_all(profile_);
    throw std::runtime_error("cannot start " + executable->string() + ": " + std::strerror(rc));
  }

  const auto deadline = Clock::now() + options.start_timeout;
  std::optional<std::pair<unsigned short, std::string>> active;
  while (!(active = read_active_port(profile_))) {
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      const std::string tail = log_tail();
      stop();
      throw std::runtime_error("Chromium exited at start-up; its log ends:\n" + tail);
    }
    if (Clock::now() > deadline) {
      const std::string tail = log_tail();
      stop();
      throw std::runtime_error("Chromium wrote no DevToolsActivePort in " +
                               std::to_string(options.start_timeout.count()) +
                               " ms; its log ends:\n" + tail);
    }
    std::this_thread::sleep_for(20ms);
  }
  port_ = active->first;
  try {
    browser_ = std::make_unique<CdpConnection>(port_, active->second, 10s);
  } catch (...) {
    stop();
    throw;
  }
}

HeadlessChromium::~HeadlessChromium() {
  stop();
}

std::unique_ptr<BrowserPage> HeadlessChromium::open_page(const std::string& url,
                                                         std::chrono::milliseconds timeout) {
  const nlohmann::json created =
      browser_->call("Target.createTarget", {{"url", "about:blank"}}, timeout);
  const std::string target = created.at("targetId").get<std::string>();
  auto page = std::make_unique<BrowserPage>(
      std::make_unique<CdpConnection>(port_, "/devtools/page/" + target, timeout), target);
  // The headless window keeps room for a browser's top bar; the page gets the whole size.
  page->connection().call("Emulation.setDeviceMetricsOverride",
                          {{"width", viewport_width_},
                           {"height", viewport_height_},
                           {"deviceScaleFactor", 1},
                           {"mobile", false}},
                          timeout);
  page->navigate(url, timeout);
  return page;
}

void HeadlessChromium::close_page(const BrowserPage& page) {
  browser_->call("Target.closeTarget", {{"targetId", page.target_id()}}, 5s);
}

std::string HeadlessChromium::log_tail(std::size_t bytes) const {
  std::ifstream in(log_file_, std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return all.size() > bytes ? all.substr(all.size() - bytes) : all;
}

void HeadlessChromium::stop() noexcept {
  if (pid_ > 0) {
    try {
      if (browser_) browser_->call("Browser.close", nlohmann::json::object(), 2s);
    } catch (...) {
      // It may not answer once it is closing; the signals below finish the job.
    }
    browser_.reset();
    int status = 0;
    const auto deadline = Clock::now() + 3s;
    bool reaped = false;
    while (Clock::now() < deadline) {
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        reaped = true;
        break;
      }
      std::this_thread::sleep_for(20ms);
    }
    ::kill(-pid_, SIGKILL);  // the group: helpers that outlive the browser process
    if (!reaped) ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }
  browser_.reset();
  std::error_code ignored;
  if (!profile_.empty()) std::filesystem::remove_all(profile_, ignored);
}

}  // namespace ioct::devtools
