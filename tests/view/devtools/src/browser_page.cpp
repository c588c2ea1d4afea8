#include "ioct/devtools/browser_page.hpp"

#include <fstream>
#include <thread>

#include "ioct/devtools/base64.hpp"

namespace ioct::devtools {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

// What DevTools says about an exception: its description (message and stack) when there is one.
std::string describe_exception(const nlohmann::json& details) {
  if (details.contains("exception")) {
    const nlohmann::json& exception = details.at("exception");
    if (exception.contains("description")) return exception.at("description").get<std::string>();
    if (exception.contains("value")) return exception.at("value").dump();
  }
  return details.value("text", "exception");
}

}  // namespace

BrowserPage::BrowserPage(std::unique_ptr<CdpConnection> connection, std::string target_id)
    : connection_(std::move(connection)), target_id_(std::move(target_id)) {
  connection_->call("Page.enable", nlohmann::json::object(), 10s);
  connection_->call("Runtime.enable", nlohmann::json::object(), 10s);
}

void BrowserPage::navigate(const std::string& url, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  connection_->take_events("Page.loadEventFired");  // an earlier page's
  const nlohmann::json result = connection_->call("Page.navigate", {{"url", url}}, timeout);
  if (result.contains("errorText")) {
    throw CdpError("cannot load " + url + ": " + result.at("errorText").get<std::string>());
  }
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  if (!connection_->wait_event("Page.loadEventFired", std::max(left, 1ms))) {
    throw CdpError(url + " did not finish loading in " + std::to_string(timeout.count()) + " ms");
  }
}

nlohmann::json BrowserPage::evaluate(const std::string& expression,
                                     std::chrono::milliseconds timeout) {
  const nlohmann::json result = connection_->call("Runtime.evaluate",
                                                  {{"expression", expression},
                                                   {"awaitPromise", true},
                                                   {"returnByValue", true},
                                                   {"timeout", timeout.count()}},
                                                  timeout + 2s);
  if (result.contains("exceptionDetails")) {
    throw JavaScriptError(describe_exception(result.at("exceptionDetails")) +
                          "\n  in: " + expression);
  }
  const nlohmann::json& value = result.at("result");
  return value.value("value", nlohmann::json());
}

std::optional<nlohmann::json> BrowserPage::wait_until(const std::string& expression,
                                                      std::chrono::milliseconds timeout,
                                                      nlohmann::json* last,
                                                      std::chrono::milliseconds poll) {
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    nlohmann::json value = evaluate(expression, 5s);
    const bool truthy = !(value.is_null() || value == false || value == 0 || value == "");
    if (last) *last = value;
    if (truthy) return value;
    if (Clock::now() + poll > deadline) return std::nullopt;
    std::this_thread::sleep_for(poll);
  }
}

std::vector<std::uint8_t> BrowserPage::screenshot_png(std::chrono::milliseconds timeout) {
  const nlohmann::json result =
      connection_->call("Page.captureScreenshot", {{"format", "png"}}, timeout);
  return decode_base64(result.at("data").get<std::string>());
}

std::uintmax_t BrowserPage::save_screenshot(const std::filesystem::path& path,
                                            std::chrono::milliseconds timeout) {
  const std::vector<std::uint8_t> png = screenshot_png(timeout);
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  if (!out) throw std::runtime_error("cannot write " + path.string());
  return png.size();
}

std::vector<std::string> BrowserPage::take_page_errors() {
  std::vector<std::string> errors;
  for (const nlohmann::json& thrown : connection_->take_events("Runtime.exceptionThrown")) {
    errors.push_back("uncaught: " + describe_exception(thrown.value("exceptionDetails",
                                                                    nlohmann::json::object())));
  }
  for (const nlohmann::json& call : connection_->take_events("Runtime.consoleAPICalled")) {
    if (call.value("type", "") != "error") continue;
    std::string line = "console.error:";
    for (const nlohmann::json& arg : call.value("args", nlohmann::json::array())) {
      line += " " + (arg.contains("value") ? arg.at("value").dump()
                                           : arg.value("description", std::string("?")));
    }
    errors.push_back(line);
  }
  return errors;
}

}  // namespace ioct::devtools
