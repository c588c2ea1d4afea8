// What the pages, scripts and the bench may do, in one place for HTTP and the WebSocket: read the
// state, change the render (operators), start/stop the scan (operators), snapshots, presets, the
// metrics. Requests are checked here (shape, role, names); values are checked once, by the
// process that owns them (render parameters by ioct-gpu, scan keys by ioct-rt), whose error names
// the key and comes back unchanged.
#pragma once

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "backends.hpp"
#include "hub.hpp"
#include "operator_token.hpp"
#include "preset_store.hpp"

namespace ioct::view {

struct ApiReply {
  unsigned status = 200;  // HTTP status (the WebSocket reply carries only the body)
  nlohmann::json body;
};
using Respond = std::function<void(ApiReply)>;

ApiReply api_error(unsigned status, const std::string& message, const std::string& key = {});

class ViewApi {
 public:
  ViewApi(Hub& hub, Backends& backends, PresetStore& presets, const OperatorToken& token,
          std::size_t max_body_bytes);

  bool is_operator_token(std::string_view token) const noexcept { return token_.matches(token); }

  // One HTTP API request (path without the query). `bearer`: the Authorization token, or empty.
  // `respond` runs on the io thread, maybe later (after ioct-gpu or ioct-rt answered).
  void http(std::string_view method, std::string_view path, std::string_view body,
            std::string_view bearer, Respond respond);

  // The operations behind both doors.
  void set_params(const nlohmann::json& changes, Respond respond);
  void scan(const nlohmann::json& request, Respond respond);
  void snapshot(const nlohmann::json& request, Respond respond);
  void save_preset(const std::string& name, Respond respond);
  void recall_preset(const std::string& name, Respond respond);
  // A viewer's own camera: `changes` may hold only the camera keys of "view".
  void set_own_view(std::uint64_t view, bool open, const nlohmann::json& changes, Respond respond);
  void close_own_view(std::uint64_t view);
  // A footswitch press: `action` (ViewConfig::footswitch_action) is carried out as the operator's
  // change it stands for, and the pages are told ({"type":"footswitch","action":...}).
  void footswitch(const std::string& action);

  // Prometheus text exposition of every process's figures.
  std::string metrics() const;

 private:
  void forward(bool to_gpu, nlohmann::json request, Respond respond);

  Hub& hub_;
  Backends& backends_;
  PresetStore& presets_;
  const OperatorToken& token_;
  std::size_t max_body_bytes_;
};

}  // namespace ioct::view
