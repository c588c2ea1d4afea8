// The view socket's requests (docs/live-view.md, "The view socket"): one JSON object per line in,
// one JSON reply out, carried out on a ViewControl. Everything in a line comes from outside and is
// checked here: strict JSON (a duplicate key is an error, not "the last one wins"), the known
// commands with exactly their fields, the parameters through render_params_json, snapshot names
// that cannot leave the snapshot folder. A bad line gets {"ok":false,"error":...,"key":...} and
// changes nothing.
//
// Private views belong to the client that opened them and are closed when it goes, so a viewer
// process that restarts leaves no renders behind. Used from one thread (the socket's).
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string_view>

#include <nlohmann/json.hpp>

#include "ioct/gpu/live_stages/view_control.hpp"

namespace ioct::gpu::live {

// Throws std::invalid_argument naming the rule unless `name` is 1 to 64 of [A-Za-z0-9._-] without
// a leading dot (so "NAME.png" can only be a file directly in the snapshot folder).
void check_snapshot_name(std::string_view name);

class ViewRequests {
 public:
  ViewRequests(ViewControl& control, std::filesystem::path snapshot_dir,
               std::chrono::milliseconds snapshot_timeout = std::chrono::seconds(10));

  // The reply to one request line of client `client`.
  nlohmann::json handle(std::string_view line, std::uint64_t client);
  // The client went: its private views are closed.
  void client_gone(std::uint64_t client);

 private:
  nlohmann::json dispatch(const nlohmann::json& request, std::uint64_t client);
  nlohmann::json snapshot(const nlohmann::json& request);
  std::uint64_t own_view(const nlohmann::json& request, std::uint64_t client);

  ViewControl& control_;
  std::filesystem::path snapshot_dir_;
  std::chrono::milliseconds snapshot_timeout_;
  std::map<std::uint64_t, std::uint64_t> view_owner_;  // private view -> client
};

}  // namespace ioct::gpu::live
