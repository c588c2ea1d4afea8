// ioct-view: the live view's web server. Serves the pages, the JSON API, /metrics and the
// WebSocket of frames and state (docs/live-view.md); reads frames from ioct-gpu's frame ring and
// passes operators' changes to ioct-gpu and ioct-rt over their local sockets. No GPU, no access to
// the group ring.
#include <unistd.h>
#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <iostream>

#include "ioct/common/command_line.hpp"
#include "ioct/common/command_main.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/common/log.hpp"
#include "operator_token.hpp"
#include "view_config.hpp"
#include "view_server.hpp"

namespace {

std::filesystem::path default_www_dir() {
  // Installed beside the binary: <prefix>/bin/ioct-view and <prefix>/share/ioct/www, or in the
  // build tree, bin/www.
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return "www";
  const std::filesystem::path bin = self.parent_path();
  if (std::filesystem::is_directory(bin / "www", ec)) return bin / "www";
  return bin.parent_path() / "share" / "ioct" / "www";
}

}  // namespace

int main(int argc, char** argv) {
  using ioct::view::ViewConfig;
  ViewConfig config;
  std::string listen = config.listen_address + ":" + std::to_string(config.port);
  std::string ring = "ioct-ring";
  std::string frames;
  std::string www;
  CLI::App app{"ioct-view: the live view of ioct in a browser (pages, API, WebSocket, metrics)"};
  app.option_defaults()->always_capture_default();
  app.add_option("--listen", listen,
                 "HOST:PORT to serve on; loopback by default (port 0: any free port)");
  app.add_option("--ring", ring, "the group ring's name; the frame ring is <ring>.frames");
  app.add_option("--frames", frames, "the frame ring's name (overrides <ring>.frames)");
  app.add_option("--view-socket", config.view_socket, "ioct-gpu's view socket");
  app.add_option("--control-socket", config.control_socket, "ioct-rt's control socket");
  app.add_option("--record-socket", config.record_socket,
                 "ioct-record's control socket, for the ioct_record_* metrics");
  app.add_option("--www", www, "folder of the pages (default: beside the executable)");
  app.add_option("--token-file", config.token_file,
                 "the operators' token (mode 0600); default: made in the state folder");
  app.add_option("--state-dir", config.state_dir, "presets, last parameters, the made token");
  app.add_option("--stale-after", config.stale_after_s,
                 "seconds without a new group before the page says STALE; 0: 3 group periods");
  app.add_option("--max-connections", config.max_connections, "open connections at most");
  app.add_option("--max-connections-per-address", config.max_connections_per_address,
                 "open connections from one remote address at most; 0: 16 on a network address, "
                 "no limit of its own on loopback (every peer is this machine)");
  app.add_option("--snapshot-timeout", config.snapshot_timeout_s,
                 "seconds a snapshot may wait for its full-size render (the CPU renderer: "
                 "seconds)");
  app.add_option("--footswitch", config.footswitch_action,
                 "what a footswitch press does: none, snapshot, next-mode, toggle-bscan or "
                 "toggle-stereo");
  if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;

  return ioct::run_command("ioct-view", [&]() -> int {
    const auto colon = listen.rfind(':');
    if (colon == std::string::npos) {
      throw ioct::ConfigError("view.listen", "'" + listen + "'", "must be HOST:PORT");
    }
    config.listen_address = listen.substr(0, colon);
    if (config.listen_address.size() > 2 && config.listen_address.front() == '[') {
      config.listen_address = config.listen_address.substr(1, config.listen_address.size() - 2);
    }
    const std::string port = listen.substr(colon + 1);
    char* end = nullptr;
    const unsigned long p = std::strtoul(port.c_str(), &end, 10);
    if (port.empty() || *end != '\0' || p > 65535) {
      throw ioct::ConfigError("view.listen", "'" + listen + "'", "the port must be 0 to 65535");
    }
    config.port = static_cast<std::uint16_t>(p);
    config.frames = frames.empty() ? ring + ".frames" : frames;
    config.www_dir = www.empty() ? default_www_dir() : std::filesystem::path(www);
    config.validate();

    const std::filesystem::path token_file =
        config.token_file.empty() ? config.state_dir / "operator-token" : config.token_file;
    const ioct::view::OperatorToken token =
        config.token_file.empty() ? ioct::view::OperatorToken::read_or_make(token_file)
                                  : ioct::view::OperatorToken::read(token_file);

    ioct::view::ViewServer server(config, token);
    const std::string host = config.listen_address == "0.0.0.0" || config.listen_address == "::"
                                 ? "localhost"
                                 : config.listen_address;
    const std::string url = "http://" +
                            (host.find(':') != std::string::npos ? "[" + host + "]" : host) + ":" +
                            std::to_string(server.port());
    std::cout << "ioct-view: surgeon's view  " << url << "/\n"
              << "ioct-view: operator's view " << url << "/control  (token in "
              << token_file.string() << ")\n"
              << std::flush;
    server.run();
    ioct::Log("ioct-view").info("stopped");
    return EXIT_SUCCESS;
  });
}
