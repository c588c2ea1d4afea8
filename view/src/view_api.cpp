#include "view_api.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <set>

#include "gpu_metrics.hpp"
#include "instrument_metrics.hpp"
#include "prometheus_text.hpp"
#include "recording_metrics.hpp"
#include "rt_metrics.hpp"
#include "strict_json.hpp"

namespace ioct::view {
namespace {

// The camera: what a viewer may change for its own view without being an operator.
const std::set<std::string>& camera_keys() {
  static const std::set<std::string> keys{
      "azimuth_deg",        "elevation_deg",   "zoom", "pan_x", "pan_y", "auto_rotate", "stereo",
      "rotation_deg_per_s", "stereo_angle_deg"};
  return keys;
}

std::string snapshot_name_now() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  const auto ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm utc{};
  gmtime_r(&t, &utc);
  char text[64];
  std::snprintf(text, sizeof text, "snapshot-%04d%02d%02d-%02d%02d%02d-%03d", utc.tm_year + 1900,
                utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec,
                static_cast<int>(ms));
  return text;
}

// A latency record as a Prometheus summary: p50, p99, sum and count.
void summary(std::string& out, const std::string& name, const std::string& help,
             const LatencyRecord& r) {
  prom::family(out, name, "summary", help);
  const std::pair<double, const char*> quantiles[] = {{0.5, "0.5"}, {0.99, "0.99"}};
  for (const auto& [q, label] : quantiles) {
    prom::sample(out, name, {{"quantile", label}}, static_cast<double>(r.quantile(q)) * 1e-9);
  }
  prom::sample(out, name + "_sum", {}, r.sum_seconds());
  prom::sample(out, name + "_count", {}, static_cast<double>(r.count()));
}

}  // namespace

ApiReply api_error(unsigned status, const std::string& message, const std::string& key) {
  nlohmann::json body = {{"ok", false}, {"error", message}};
  if (!key.empty()) body["key"] = key;
  return {status, std::move(body)};
}

ViewApi::ViewApi(Hub& hub, Backends& backends, PresetStore& presets, const OperatorToken& token,
                 std::size_t max_body_bytes)
    : hub_(hub),
      backends_(backends),
      presets_(presets),
      token_(token),
      max_body_bytes_(max_body_bytes) {}

void ViewApi::forward(bool to_gpu, nlohmann::json request, Respond respond) {
  auto on_reply = [respond](nlohmann::json reply) {
    if (reply.value("ok", false)) return respond({200, std::move(reply)});
    const unsigned status = reply.value("unavailable", false) ? 503 : 400;
    reply.erase("unavailable");
    respond({status, std::move(reply)});
  };
  const bool queued = to_gpu ? backends_.gpu(std::move(request), on_reply)
                             : backends_.rt(std::move(request), on_reply);
  if (!queued) respond(api_error(429, "too many requests waiting; try again"));
}

void ViewApi::set_params(const nlohmann::json& changes, Respond respond) {
  if (!changes.is_object()) return respond(api_error(400, "changes must be a JSON object"));
  forward(true, {{"cmd", "set"}, {"changes", changes}}, std::move(respond));
}

void ViewApi::scan(const nlohmann::json& request, Respond respond) {
  if (!request.is_object() || !request.contains("cmd") || !request["cmd"].is_string()) {
    return respond(api_error(400, "a scan request needs \"cmd\": start, stop or scan", "cmd"));
  }
  const std::string cmd = request["cmd"].get<std::string>();
  for (const auto& [key, value] : request.items()) {
    if (key != "cmd" && key != "scan" && key != "id" && key != "type") {
      return respond(api_error(400, "unknown key " + quote_input(key) + " in a scan request", key));
    }
  }
  if (cmd == "start" || cmd == "stop") return forward(false, {{"cmd", cmd}}, std::move(respond));
  if (cmd == "scan") {
    if (!request.contains("scan") || !request["scan"].is_object()) {
      return respond(api_error(400, "\"scan\" must be an object of scan keys", "scan"));
    }
    return forward(false, {{"cmd", "scan"}, {"scan", request["scan"]}}, std::move(respond));
  }
  respond(api_error(400, "cmd " + quote_input(cmd) + " is not start, stop or scan", "cmd"));
}

void ViewApi::snapshot(const nlohmann::json& request, Respond respond) {
  std::string name = snapshot_name_now();
  if (request.is_object() && request.contains("name")) {
    if (!request["name"].is_string() ||
        !PresetStore::valid_name(request["name"].get<std::string>())) {
      return respond(api_error(400, "name must be 1 to 64 of A-Z a-z 0-9 _ -", "name"));
    }
    name = request["name"].get<std::string>();
  }
  forward(true, {{"cmd", "snapshot"}, {"name", name}}, std::move(respond));
}

void ViewApi::save_preset(const std::string& name, Respond respond) {
  if (!PresetStore::valid_name(name)) {
    return respond(api_error(400, "a preset name is 1 to 64 of A-Z a-z 0-9 _ -", "name"));
  }
  const nlohmann::json& params = hub_.backends().params;
  if (!params.is_object()) {
    return respond(api_error(503, "no parameters to save: ioct-gpu is not reachable"));
  }
  try {
    presets_.save(name, params);
  } catch (const std::exception& e) {
    return respond(api_error(500, std::string("cannot save the preset: ") + e.what()));
  }
  respond({200, {{"ok", true}, {"preset", name}}});
}

void ViewApi::recall_preset(const std::string& name, Respond respond) {
  std::optional<nlohmann::json> params;
  try {
    params = presets_.load(name);
  } catch (const std::exception& e) {
    return respond(api_error(500, std::string("the preset's file cannot be used: ") + e.what()));
  }
  if (!params) return respond(api_error(404, "no preset named " + quote_input(name), "name"));
  set_params(*params, std::move(respond));
}

void ViewApi::set_own_view(std::uint64_t view, bool open, const nlohmann::json& changes,
                           Respond respond) {
  if (!changes.is_object()) return respond(api_error(400, "changes must be a JSON object"));
  for (const auto& [key, value] : changes.items()) {
    if (key != "view" || !value.is_object()) {
      return respond(api_error(400, "a viewer's own view takes only \"view\" camera keys", key));
    }
    for (const auto& [camera_key, v] : value.items()) {
      if (!camera_keys().contains(camera_key)) {
        return respond(api_error(400,
                                 "view." + camera_key + " is not a camera key a viewer may set",
                                 "view." + camera_key));
      }
    }
  }
  nlohmann::json request = {
      {"cmd", open ? "open_view" : "set"}, {"view", view}, {"changes", changes}};
  forward(true, std::move(request), std::move(respond));
}

void ViewApi::close_own_view(std::uint64_t view) {
  (void)backends_.gpu({{"cmd", "close_view"}, {"view", view}}, [](nlohmann::json) {});
}

void ViewApi::footswitch(const std::string& action) {
  hub_.broadcast_event(nlohmann::json{{"type", "footswitch"}, {"action", action}}.dump());
  const auto ignore = [](ApiReply) {};
  const nlohmann::json& params = hub_.backends().params;
  if (action == "snapshot") {
    snapshot(nlohmann::json::object(), ignore);
  } else if (action == "next-mode" && params.is_object()) {
    static const char* const kModes[] = {"enhanced", "layer-aware", "la-mip", "axial-colorization",
                                         "basic"};
    const std::string mode = params.contains("mode") && params["mode"].is_string()
                                 ? params["mode"].get<std::string>()
                                 : std::string();
    std::size_t next = 0;
    for (std::size_t i = 0; i < std::size(kModes); ++i) {
      if (mode == kModes[i]) next = (i + 1) % std::size(kModes);
    }
    set_params({{"mode", kModes[next]}}, ignore);
  } else if (action == "toggle-stereo" && params.is_object() && params.contains("view")) {
    const nlohmann::json& view = params["view"];
    const bool stereo = view.is_object() && view.contains("stereo") && view["stereo"] == true;
    set_params({{"view", {{"stereo", !stereo}}}}, ignore);
  }
  // toggle-bscan is the pages' own: they show or hide their B-scan panel.
}

void ViewApi::http(std::string_view method, std::string_view path, std::string_view body,
                   std::string_view bearer, Respond respond) {
  const bool is_operator = !bearer.empty() && token_.matches(bearer);
  const auto parse_body = [&](nlohmann::json& out) -> bool {
    if (body.empty()) {
      out = nlohmann::json::object();
      return true;
    }
    try {
      out = parse_strict_json(body, max_body_bytes_);
    } catch (const BadMessage& e) {
      respond(api_error(400, std::string("request body: ") + e.what(), e.key()));
      return false;
    }
    return true;
  };
  const auto need_operator = [&]() {
    if (is_operator) return true;
    respond(api_error(401, bearer.empty()
                               ? "changes need the operator token (Authorization: Bearer)"
                               : "the operator token is wrong"));
    return false;
  };

  if (path == "/api/state" && method == "GET") {
    return respond({200, hub_.state(is_operator ? "operator" : "viewer")});
  }
  if (path == "/api/params") {
    if (method == "GET") {
      const BackendsSnapshot& b = hub_.backends();
      if (!b.params.is_object()) return respond(api_error(503, "ioct-gpu: " + b.gpu_error));
      return respond({200, {{"ok", true}, {"generation", b.generation}, {"params", b.params}}});
    }
    if (method == "POST") {
      nlohmann::json changes;
      if (!need_operator() || !parse_body(changes)) return;
      return set_params(changes, std::move(respond));
    }
  }
  if (path == "/api/scan" && method == "POST") {
    nlohmann::json request;
    if (!need_operator() || !parse_body(request)) return;
    return scan(request, std::move(respond));
  }
  if (path == "/api/snapshot" && method == "POST") {
    nlohmann::json request;
    if (!need_operator() || !parse_body(request)) return;
    return snapshot(request, std::move(respond));
  }
  if (path == "/api/presets" && method == "GET") {
    return respond({200, {{"ok", true}, {"presets", presets_.names()}}});
  }
  constexpr std::string_view presets_prefix = "/api/presets/";
  if (path.substr(0, presets_prefix.size()) == presets_prefix) {
    std::string rest(path.substr(presets_prefix.size()));
    const bool recall = rest.size() > 7 && rest.compare(rest.size() - 7, 7, "/recall") == 0;
    if (recall) rest.resize(rest.size() - 7);
    if (!PresetStore::valid_name(rest)) {
      return respond(api_error(400, "a preset name is 1 to 64 of A-Z a-z 0-9 _ -", "name"));
    }
    if (!recall && method == "PUT") {
      if (!need_operator()) return;
      return save_preset(rest, std::move(respond));
    }
    if (recall && method == "POST") {
      if (!need_operator()) return;
      return recall_preset(rest, std::move(respond));
    }
    if (!recall && method == "DELETE") {
      if (!need_operator()) return;
      if (!presets_.remove(rest)) return respond(api_error(404, "no preset named '" + rest + "'"));
      return respond({200, {{"ok", true}}});
    }
    if (!recall && method == "GET") {
      std::optional<nlohmann::json> p;
      try {
        p = presets_.load(rest);
      } catch (const std::exception& e) {
        return respond(
            api_error(500, std::string("the preset's file cannot be used: ") + e.what()));
      }
      if (!p) return respond(api_error(404, "no preset named '" + rest + "'"));
      return respond({200, {{"ok", true}, {"params", *p}}});
    }
  }
  respond(api_error(
      404, "no such API call: " + quote_input(std::string(method) + " " + std::string(path), 80)));
}

std::string ViewApi::metrics() const {
  std::string out;
  const FollowerSnapshot& f = hub_.follower();
  auto& hub = const_cast<Hub&>(hub_);
  prom::single(out, "ioct_view_signal_live", "gauge", "1 while the page shows live data",
               f.verdict.signal == Signal::live ? 1 : 0);
  prom::single(out, "ioct_view_group_age_seconds", "gauge", "age of the newest group",
               static_cast<double>(f.verdict.age_ns) * 1e-9);
  prom::single(out, "ioct_view_viewers", "gauge", "connected WebSocket viewers",
               static_cast<double>(hub_.viewers()));
  const HubCounters& c = hub.counters();
  prom::single(out, "ioct_view_frames_in_total", "counter", "frames read from the frame ring",
               static_cast<double>(c.frames_in));
  prom::single(out, "ioct_view_frames_sent_total", "counter", "frames sent to viewers",
               static_cast<double>(c.frames_sent));
  prom::single(out, "ioct_view_frames_replaced_total", "counter",
               "frames a slow viewer never got because a newer one replaced them",
               static_cast<double>(c.frames_replaced));
  prom::single(out, "ioct_view_frames_skipped_total", "counter",
               "frames overwritten in the frame ring before ioct-view read them",
               static_cast<double>(f.frames_skipped));
  prom::single(out, "ioct_view_messages_refused_total", "counter", "browser messages refused",
               static_cast<double>(c.messages_refused));
  prom::single(out, "ioct_view_connections_refused_total", "counter",
               "connections refused at the limit", static_cast<double>(c.connections_refused));
  summary(out, "ioct_view_published_to_sent_seconds",
          "group published by ioct-rt to its frame sent on the WebSocket", hub.published_to_sent());
  summary(out, "ioct_view_published_to_drawn_seconds",
          "group published by ioct-rt to its frame drawn by a page", hub.published_to_drawn());
  append_gpu_metrics(out, f);
  write_instrument_metrics(hub_.instrument(), f.attached && f.writer_responding, out);
  append_rt_metrics(out, hub_.backends().rt_status);
  write_recording_metrics(hub_.backends().record_status, out);
  return out;
}

}  // namespace ioct::view
