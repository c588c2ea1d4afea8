#include "ioct/gpu/live_stages/view_requests.hpp"

#include "ioct/common/strict_json.hpp"

#include <algorithm>
#include <chrono>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "ioct/common/atomic_file.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/gpu/render/png_rgba.hpp"

namespace ioct::gpu::live {
namespace {

using nlohmann::json;

// A refusal naming what was wrong; `key` says which field (or "request" for the line itself).
class RequestError : public std::runtime_error {
 public:
  RequestError(std::string key, const std::string& what)
      : std::runtime_error(what), key_(std::move(key)) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

json refusal(const std::string& key, const std::string& error) {
  return {{"ok", false}, {"error", error}, {"key", key}};
}

// As JSON, every byte outside printable ASCII escaped (\u007f, \u00e9): a message never carries
// the client's raw bytes.
std::string ascii_json(const json& value) {
  return value.dump(-1, ' ', true);
}

std::string shown(const json& value) {
  std::string text = ascii_json(value);
  if (text.size() > 60) text = text.substr(0, 60) + "...";
  return text;
}

// JSON whose objects have each key once.
json parse_strict(std::string_view line) {
  StrictJson parsed = parse_json_strictly(line);
  if (parsed.value.is_discarded()) {
    throw RequestError("request", "not JSON: " + parsed.error);
  }
  if (!parsed.duplicate_key.empty()) {
    throw RequestError("request",
                       "duplicate key \"" + parsed.duplicate_key + "\" (each key may appear once)");
  }
  return std::move(parsed.value);
}

// Refuses fields the command does not take.
void only_fields(const json& request, std::initializer_list<std::string_view> allowed) {
  for (const auto& [name, value] : request.items()) {
    if (std::ranges::find(allowed, name) == allowed.end()) {
      throw RequestError(name, ascii_json(name) + " = " + shown(value) + ": not a field of " +
                                   request.at("cmd").get<std::string>());
    }
  }
}

// A private view's number: 1 .. 2^53 (what a JavaScript number holds exactly).
std::uint64_t view_number(const json& request) {
  const auto it = request.find("view");
  if (it == request.end()) throw RequestError("view", "view is missing");
  constexpr std::uint64_t kMax = 1ull << 53;
  if (!it->is_number_integer() ||
      (it->is_number_unsigned() ? it->get<std::uint64_t>() > kMax : it->get<std::int64_t>() < 1)) {
    throw RequestError("view", "view = " + shown(*it) + ": must be a whole number from 1 to 2^53");
  }
  const auto view = it->get<std::uint64_t>();
  if (view == 0) throw RequestError("view", "view = 0: the shared view is changed without view");
  return view;
}

const json& changes_of(const json& request, bool required) {
  static const json kNone = json::object();
  const auto it = request.find("changes");
  if (it == request.end()) {
    if (required) throw RequestError("changes", "changes is missing");
    return kNone;
  }
  if (!it->is_object()) {
    throw RequestError("changes", "changes = " + shown(*it) + ": must be an object");
  }
  return *it;
}

std::string default_snapshot_name() {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
  return "snapshot-" + std::to_string(ms);
}

}  // namespace

void check_snapshot_name(std::string_view name) {
  const bool allowed = std::ranges::all_of(name, [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
           c == '_' || c == '-';
  });
  if (name.empty() || name.size() > 64 || !allowed || name.front() == '.') {
    throw std::invalid_argument("must be 1 to 64 of A-Z a-z 0-9 . _ - and not start with a dot");
  }
}

ViewRequests::ViewRequests(ViewControl& control, std::filesystem::path snapshot_dir,
                           std::chrono::milliseconds snapshot_timeout)
    : control_(control),
      snapshot_dir_(std::move(snapshot_dir)),
      snapshot_timeout_(snapshot_timeout) {}

json ViewRequests::handle(std::string_view line, std::uint64_t client) {
  try {
    return dispatch(parse_strict(line), client);
  } catch (const RequestError& e) {
    return refusal(e.key(), e.what());
  } catch (const ConfigError& e) {
    return refusal(e.key(), e.what());
  } catch (const std::exception& e) {
    return refusal("request", e.what());
  }
}

json ViewRequests::dispatch(const json& request, std::uint64_t client) {
  if (!request.is_object()) {
    throw RequestError("request", "request = " + shown(request) + ": must be a JSON object");
  }
  const auto cmd_field = request.find("cmd");
  if (cmd_field == request.end() || !cmd_field->is_string()) {
    throw RequestError("cmd", "cmd is missing or not a string");
  }
  const std::string cmd = cmd_field->get<std::string>();
  if (cmd == "get") {
    only_fields(request, {"cmd"});
    const ViewParams p = control_.params();
    return {{"ok", true}, {"generation", p.generation}, {"params", p.params}};
  }
  if (cmd == "instruments") {
    only_fields(request, {"cmd"});
    return {{"ok", true}, {"instruments", control_.instruments()}};
  }
  if (cmd == "set") {
    only_fields(request, {"cmd", "view", "changes"});
    const json& changes = changes_of(request, true);
    std::uint64_t generation = 0;
    if (request.contains("view")) {
      generation = control_.set_view(own_view(request, client), changes);
    } else {
      generation = control_.set_params(changes);
    }
    return {{"ok", true}, {"generation", generation}};
  }
  if (cmd == "open_view") {
    only_fields(request, {"cmd", "view", "changes"});
    const std::uint64_t view = view_number(request);
    const auto owner = view_owner_.find(view);
    if (owner != view_owner_.end() && owner->second != client) {
      throw RequestError("view", "view " + std::to_string(view) + " is another client's");
    }
    try {
      control_.open_view(view, changes_of(request, false));
    } catch (const std::invalid_argument& e) {
      if (dynamic_cast<const ConfigError*>(&e) != nullptr) throw;
      throw RequestError("view", e.what());
    }
    view_owner_[view] = client;
    return {{"ok", true}, {"view", view}};
  }
  if (cmd == "close_view") {
    only_fields(request, {"cmd", "view"});
    const std::uint64_t view = own_view(request, client);
    control_.close_view(view);
    view_owner_.erase(view);
    return {{"ok", true}};
  }
  if (cmd == "snapshot") {
    only_fields(request, {"cmd", "name"});
    return snapshot(request);
  }
  throw RequestError("cmd", "cmd = " + shown(*cmd_field) +
                                ": must be get, set, open_view, close_view or snapshot");
}

std::uint64_t ViewRequests::own_view(const json& request, std::uint64_t client) {
  const std::uint64_t view = view_number(request);
  const auto owner = view_owner_.find(view);
  if (owner == view_owner_.end() || owner->second != client) {
    throw RequestError("view", "view " + std::to_string(view) + " is not open on this connection");
  }
  return view;
}

json ViewRequests::snapshot(const json& request) {
  std::string name = default_snapshot_name();
  if (const auto it = request.find("name"); it != request.end()) {
    if (!it->is_string()) throw RequestError("name", "name = " + shown(*it) + ": must be a string");
    name = it->get<std::string>();
  }
  try {
    check_snapshot_name(name);
  } catch (const std::invalid_argument& e) {
    throw RequestError("name", "name = " + ascii_json(name) + ": " + e.what());
  }
  std::error_code ec;
  std::filesystem::create_directories(snapshot_dir_, ec);
  const std::filesystem::path png = std::filesystem::absolute(snapshot_dir_ / (name + ".png"));
  const std::filesystem::path params = std::filesystem::absolute(snapshot_dir_ / (name + ".json"));
  // Never over an earlier snapshot (or whatever else lies there, links included).
  for (const auto& path : {png, params}) {
    if (std::filesystem::exists(std::filesystem::symlink_status(path, ec))) {
      throw RequestError("name", "name = " + ascii_json(name) + ": " + path.filename().string() +
                                     " exists in the snapshot folder");
    }
  }
  ViewSnapshot shot;
  try {
    shot = control_.snapshot(snapshot_timeout_);
  } catch (const std::exception& e) {
    throw RequestError("snapshot", std::string("no snapshot: ") + e.what());
  }
  render::write_png(png, shot.image);
  const json described = {{"generation", shot.generation},
                          {"group", shot.group_index},
                          {"width", shot.image.width},
                          {"height", shot.image.height},
                          {"params", shot.params}};
  write_text_file_atomically(params, described.dump(2) + "\n");
  return {{"ok", true},
          {"png", png.string()},
          {"json", params.string()},
          {"generation", shot.generation},
          {"group", shot.group_index}};
}

void ViewRequests::client_gone(std::uint64_t client) {
  for (auto it = view_owner_.begin(); it != view_owner_.end();) {
    if (it->second == client) {
      control_.close_view(it->first);
      it = view_owner_.erase(it);
    } else {
      ++it;
    }
  }
}

}  // namespace ioct::gpu::live
