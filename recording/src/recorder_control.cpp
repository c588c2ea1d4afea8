#include "ioct/ringrec/recorder_control.hpp"

#include <poll.h>

#include <vector>

#include "ioct/common/strict_json.hpp"

namespace ioct::ringrec {
namespace {

constexpr const char* kVerbs = "record-start, record-stop, record-status";

nlohmann::json counters_json(const CounterValues& c) {
  auto at = [&](Counter k) { return c[static_cast<std::size_t>(k)]; };
  return {{"groups_written", at(Counter::groups_written)},
          {"bytes_written", at(Counter::bytes_written)},
          {"producer_restarts", at(Counter::producer_restarts)},
          {"dropped",
           {{"lapped", at(Counter::dropped_lapped)},
            {"behind", at(Counter::dropped_behind)},
            {"queue_full", at(Counter::dropped_queue_full)},
            {"disk_full", at(Counter::dropped_disk_full)}}}};
}

nlohmann::json ok_reply(const std::string& cmd, const nlohmann::json& id,
                        const RecorderStatus& status) {
  nlohmann::json reply = {{"ok", true}, {"cmd", cmd}, {"status", recorder_status_json(status)}};
  if (!id.is_null()) reply["id"] = id;
  return reply;
}

}  // namespace

nlohmann::json recorder_status_json(const RecorderStatus& s) {
  nlohmann::json j = counters_json(s.counters);
  j["recording"] = s.recording;
  j["standby"] = s.standby;
  j["attached"] = s.attached;
  j["file"] = s.recording ? nlohmann::json(s.file.string()) : nlohmann::json(nullptr);
  j["seconds"] = s.seconds;
  j["limit_seconds"] = s.limit_seconds;
  j["queue"] = {{"queued", s.queued}, {"capacity", s.queue_capacity}};
  if (s.last) {
    nlohmann::json last = counters_json(s.last->counters);
    last["file"] = s.last->file.string();
    last["stop_reason"] = s.last->stop_reason;
    last["failed"] = s.last->failed;
    last["seconds"] = s.last->seconds;
    j["last"] = last;
  } else {
    j["last"] = nullptr;
  }
  return j;
}

std::string recorder_control_reply(RingRecorder& recorder, const std::string& line) {
  try {
    if (line.size() > kMaxControlLineBytes) {
      return error_reply("line longer than " + std::to_string(kMaxControlLineBytes) + " bytes");
    }
    const StrictJson parsed = parse_json_strictly(line);
    const nlohmann::json& doc = parsed.value;
    if (doc.is_discarded() || !doc.is_object()) {
      return error_reply(
          "expected one JSON object per line, like {\"cmd\": \"record-status\"}; verbs: " +
          std::string(kVerbs));
    }
    if (!parsed.duplicate_key.empty()) {
      return error_reply("key " + shown_json(nlohmann::json(parsed.duplicate_key)) +
                         " given twice in one object; each key once");
    }
    nlohmann::json id = nullptr;
    if (const auto it = doc.find("id"); it != doc.end()) id = *it;
    const auto cmd = doc.find("cmd");
    if (cmd == doc.end() || !cmd->is_string()) {
      return error_reply("missing or non-string \"cmd\"; verbs: " + std::string(kVerbs), id);
    }
    const std::string verb = cmd->get<std::string>();
    if (verb != "record-start" && verb != "record-stop" && verb != "record-status") {
      return error_reply("unknown verb " + shown_json(*cmd) + "; verbs: " + kVerbs, id);
    }
    for (const auto& [key, value] : doc.items()) {
      if (key == "cmd" || key == "id") continue;
      if (verb == "record-start" && (key == "name" || key == "seconds")) continue;
      return error_reply("unexpected member " + shown_json(nlohmann::json(key)) + " in a \"" +
                             verb + "\" command" +
                             (verb == "record-start" ? " (it takes name and seconds)" : ""),
                         id, verb);
    }
    std::string refusal;
    if (verb == "record-start") {
      const auto name = doc.find("name");
      if (name == doc.end() || !name->is_string()) {
        return error_reply(
            "record-start needs \"name\": the recording's file name in the --out directory, "
            "e.g. {\"cmd\": \"record-start\", \"name\": \"run-7\"}",
            id, verb);
      }
      double seconds = 0.0;
      if (const auto s = doc.find("seconds"); s != doc.end()) {
        if (!s->is_number()) {
          return error_reply("record-start: seconds = " + shown_json(*s) + ": must be a number", id,
                             verb);
        }
        seconds = s->get<double>();
      }
      refusal = recorder.start_recording(name->get<std::string>(), seconds);
    } else if (verb == "record-stop") {
      refusal = recorder.stop_recording();
    }
    if (!refusal.empty()) return error_reply(refusal, id, verb);
    return ok_reply(verb, id, recorder.status())
        .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  } catch (const std::exception& e) {
    return error_reply(std::string("internal error: ") + e.what());
  }
}

void serve_recorder_control(LineServer& server, RingRecorder& recorder,
                            const std::atomic<bool>& done) {
  std::vector<pollfd> fds;
  const LineServer::Handler handler = [&recorder](const std::string& line) {
    return recorder_control_reply(recorder, line);
  };
  while (!done.load(std::memory_order_acquire)) {
    fds.clear();
    server.add_poll_fds(fds);
    ::poll(fds.data(), fds.size(), 100);  // 100 ms: `done` is seen without a wake-up pipe
    server.process(fds.data(), fds.size(), handler);
  }
}

}  // namespace ioct::ringrec
