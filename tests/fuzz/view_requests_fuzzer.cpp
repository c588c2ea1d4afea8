// ioct-gpu's view socket requests (gpu/live_stages view_requests): one line as ioct-view or a
// script sends it, handled by the real ViewRequests on a stand-in for the render stages. The reply
// is always an object with "ok", and a refusal's error is a readable message.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include "input_files.hpp"
#include "ioct/gpu/live_stages/view_requests.hpp"
#include "refusal.hpp"

namespace {

// The render stages' side of the view socket, without rendering: every change is taken (the
// parameters' own checks are render_params_json's), a private view must be open to be steered,
// and there is never a frame to snapshot.
class StandInControl final : public ioct::gpu::live::ViewControl {
 public:
  ioct::gpu::live::ViewParams params() const override {
    return {generation_, nlohmann::json::object()};
  }
  std::uint64_t set_params(const nlohmann::json&) override { return ++generation_; }
  std::uint64_t open_view(std::uint64_t view, const nlohmann::json&) override {
    if (view == 0) throw std::invalid_argument("view 0 is the shared view");
    return ++generation_;
  }
  std::uint64_t set_view(std::uint64_t view, const nlohmann::json&) override {
    if (view == 0) throw std::out_of_range("view 0 is not open");
    return ++generation_;
  }
  void close_view(std::uint64_t) override {}
  ioct::gpu::live::ViewSnapshot snapshot(std::chrono::milliseconds) override {
    throw std::runtime_error("nothing rendered yet");
  }

 private:
  std::uint64_t generation_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static ioct::fuzz::ScratchDirectory snapshots;
  static StandInControl control;
  static ioct::gpu::live::ViewRequests requests(control, snapshots.path(),
                                                std::chrono::milliseconds(1));
  const std::string_view line(reinterpret_cast<const char*>(data), size);
  const nlohmann::json reply = requests.handle(line, 1);
  if (!reply.is_object() || !reply.contains("ok") || !reply["ok"].is_boolean()) {
    ioct::fuzz::finding("a reply without \"ok\"", reply.dump());
  }
  if (!reply["ok"].get<bool>()) {
    if (!reply.contains("error") || !reply["error"].is_string()) {
      ioct::fuzz::finding("a refusal without an error message", reply.dump());
    }
    ioct::fuzz::check_message(reply["error"].get<std::string>());
  }
  requests.client_gone(1);
  return 0;
}
