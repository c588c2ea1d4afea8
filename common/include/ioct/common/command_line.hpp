// How every command reads its command line (CLI11): --help prints the help and ends with 0, a
// mistake prints CLI11's message and ends with kExitRefused (2), like any refused configuration,
// instead of CLI11's own codes (105, 106, ...).
#pragma once

#include <CLI/CLI.hpp>

#include <optional>

#include "ioct/common/error.hpp"

namespace ioct {

// The exit status when the command should end now, or nullopt to go on:
//   if (const auto status = ioct::parse_command_line(app, argc, argv)) return *status;
inline std::optional<int> parse_command_line(CLI::App& app, int argc, const char* const* argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitRefused;
  }
  return std::nullopt;
}

}  // namespace ioct
