// ioct-rtctl: one request to ioct-rt's control socket, its reply on stdout.
//   ioct-rtctl [--socket PATH] status | start | stop | scan KEY=VALUE... | raw 'JSON LINE'
// Exit status 0 when the reply says "ok": true, 1 when it does not, 2 when there was no reply.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ioct/common/line_client.hpp"

namespace {

nlohmann::json scalar(const std::string& text) {
  const nlohmann::json parsed = nlohmann::json::parse(text, nullptr, false);
  if (!parsed.is_discarded() && (parsed.is_number() || parsed.is_boolean())) return parsed;
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ioct-rtctl: send one command to ioct-rt's control socket and print the reply"};
  std::string socket_path = "/run/ioct/rt.sock";
  double timeout_s = 5.0;
  std::string verb;
  std::vector<std::string> arguments;
  app.add_option("--socket", socket_path, "ioct-rt's control socket (control.socket)")
      ->capture_default_str();
  app.add_option("--timeout", timeout_s, "seconds to wait for the reply")->capture_default_str();
  app.add_option("command", verb, "status, start, stop, scan KEY=VALUE..., or raw LINE")
      ->required()
      ->check(CLI::IsMember({"status", "start", "stop", "scan", "raw"}));
  app.add_option("arguments", arguments, "scan: KEY=VALUE pairs; raw: the line to send");
  CLI11_PARSE(app, argc, argv);

  std::string line;
  if (verb == "raw") {
    for (const std::string& a : arguments) line += (line.empty() ? "" : " ") + a;
  } else {
    nlohmann::json request = {{"cmd", verb}};
    if (verb == "scan") {
      nlohmann::json scan = nlohmann::json::object();
      for (const std::string& a : arguments) {
        const auto eq = a.find('=');
        if (eq == std::string::npos) {
          std::fprintf(stderr, "ioct-rtctl: scan takes KEY=VALUE pairs, not \"%s\"\n", a.c_str());
          return 2;
        }
        scan[a.substr(0, eq)] = scalar(a.substr(eq + 1));
      }
      request["scan"] = scan;
    }
    line = request.dump();
  }

  ioct::LineClient client(socket_path, std::chrono::milliseconds(static_cast<std::int64_t>(
                                           std::clamp(timeout_s, 0.001, 3600.0) * 1000.0)));
  const auto reply = client.request(line);
  if (!reply) {
    std::fprintf(stderr, "ioct-rtctl: %s\n", client.last_error().c_str());
    return 2;
  }
  std::printf("%s\n", reply->c_str());
  const nlohmann::json parsed = nlohmann::json::parse(*reply, nullptr, false);
  return !parsed.is_discarded() && parsed.value("ok", false) ? 0 : 1;
}
