// ioct-rtctl: one request to ioct-rt's control socket, its reply on stdout.
//   ioct-rtctl [--socket PATH] status | start | stop | scan KEY=VALUE... | raw 'JSON LINE'
// Exit status 0 when the reply says "ok": true, 1 when it does not, 2 when there was no reply.
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

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

  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (socket_path.size() >= sizeof(address.sun_path)) {
    std::fprintf(stderr, "ioct-rtctl: socket path too long\n");
    return 2;
  }
  std::memcpy(address.sun_path, socket_path.c_str(), socket_path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0 || ::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) != 0) {
    std::fprintf(stderr, "ioct-rtctl: cannot connect to %s: %s\n", socket_path.c_str(),
                 std::strerror(errno));
    return 2;
  }
  line += '\n';
  if (::send(fd, line.data(), line.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(line.size())) {
    std::fprintf(stderr, "ioct-rtctl: send failed: %s\n", std::strerror(errno));
    return 2;
  }
  std::string reply;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (reply.find('\n') == std::string::npos) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        end - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) break;
    char buffer[4096];
    const ssize_t got = ::recv(fd, buffer, sizeof(buffer), 0);
    if (got <= 0) break;
    reply.append(buffer, static_cast<std::size_t>(got));
  }
  ::close(fd);
  const auto newline = reply.find('\n');
  if (newline == std::string::npos) {
    std::fprintf(stderr, "ioct-rtctl: no reply from %s\n", socket_path.c_str());
    return 2;
  }
  reply.resize(newline);
  std::printf("%s\n", reply.c_str());
  const nlohmann::json parsed = nlohmann::json::parse(reply, nullptr, false);
  return !parsed.is_discarded() && parsed.value("ok", false) ? 0 : 1;
}
