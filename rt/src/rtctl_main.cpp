// ioct-rtctl: one request to ioct-rt's control socket (or ioct-record's), its reply on stdout.
//   ioct-rtctl [--socket PATH] status | start | stop | scan KEY=VALUE... | raw 'JSON LINE'
//   ioct-rtctl [--socket PATH] record-start NAME [SECONDS] | record-stop | record-status
// The record-* verbs go to the recorder's socket (/run/ioct-record/record.sock unless --socket
// says). Exit status 0 when the reply says "ok": true, 1 when it does not, 2 when there was no
// reply.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ioct/common/command_line.hpp"
#include "ioct/common/line_client.hpp"
#include "ioct/common/log.hpp"

namespace {

nlohmann::json scalar(const std::string& text) {
  nlohmann::json parsed = nlohmann::json::parse(text, nullptr, false);
  if (!parsed.is_discarded() && (parsed.is_number() || parsed.is_boolean())) return parsed;
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ioct-rtctl: send one command to ioct-rt's control socket and print the reply"};
  std::string socket_path;
  double timeout_s = 5.0;
  std::string verb;
  std::vector<std::string> arguments;
  app.add_option(
      "--socket", socket_path,
      "the control socket: ioct-rt's (control.socket; default /run/ioct/rt.sock) or, "
      "for record-*, ioct-record's (--control-socket; default /run/ioct-record/record.sock)");
  app.add_option("--timeout", timeout_s, "seconds to wait for the reply")->capture_default_str();
  app.add_option("command", verb,
                 "status, start, stop, scan KEY=VALUE..., raw LINE (ioct-rt); record-start NAME "
                 "[SECONDS], record-stop, record-status (ioct-record)")
      ->required()
      ->check(CLI::IsMember({"status", "start", "stop", "scan", "raw", "record-start",
                             "record-stop", "record-status"}));
  app.add_option("arguments", arguments,
                 "scan: KEY=VALUE pairs; raw: the line to send; record-start: NAME [SECONDS]");
  if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;
  const ioct::Log log("ioct-rtctl");
  const bool to_recorder = verb.rfind("record-", 0) == 0;
  if (socket_path.empty())
    socket_path = to_recorder ? "/run/ioct-record/record.sock" : "/run/ioct/rt.sock";

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
          log.error("scan takes KEY=VALUE pairs, not \"" + a + "\"");
          return 2;
        }
        scan[a.substr(0, eq)] = scalar(a.substr(eq + 1));
      }
      request["scan"] = scan;
    } else if (verb == "record-start") {
      if (arguments.empty() || arguments.size() > 2) {
        log.error("record-start takes NAME [SECONDS], not " + std::to_string(arguments.size()) +
                  " arguments");
        return 2;
      }
      request["name"] = arguments[0];
      if (arguments.size() == 2) {
        const nlohmann::json seconds = scalar(arguments[1]);
        if (!seconds.is_number()) {
          log.error("record-start SECONDS = \"" + arguments[1] + "\": not a number");
          return 2;
        }
        request["seconds"] = seconds;
      }
    } else if (!arguments.empty()) {
      log.error(verb + " takes no arguments");
      return 2;
    }
    line = request.dump();
  }

  ioct::LineClient client(socket_path, std::chrono::milliseconds(static_cast<std::int64_t>(
                                           std::clamp(timeout_s, 0.001, 3600.0) * 1000.0)));
  const auto reply = client.request(line);
  if (!reply) {
    log.error(client.last_error());
    return 2;
  }
  std::printf("%s\n", reply->c_str());
  const nlohmann::json parsed = nlohmann::json::parse(*reply, nullptr, false);
  return !parsed.is_discarded() && parsed.value("ok", false) ? 0 : 1;
}
