#include "frame_message.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace ioct::view {
namespace {

double ms_between(std::uint64_t from, std::uint64_t to) {
  return from != 0 && to >= from ? static_cast<double>(to - from) * 1e-6 : 0.0;
}

nlohmann::json number(float v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

// The instrument the frame shows (docs/live-view.md, "Instrument"): state off / none / found;
// for a tip its position and its signed distances to the ILM and the RPE, and where the surfaces
// at the tip came from (measured / inferred / none).
nlohmann::json instrument_json(const shm::FrameInstrument& in) {
  const auto state = static_cast<shm::FrameInstrumentState>(in.state);
  if (state == shm::FrameInstrumentState::none) return {{"state", "none"}};
  if (state != shm::FrameInstrumentState::found) return {{"state", "off"}};
  const char* source = "none";
  switch (static_cast<shm::FrameDistanceSource>(in.distance_source)) {
    case shm::FrameDistanceSource::measured:
      source = "measured";
      break;
    case shm::FrameDistanceSource::inferred:
      source = "inferred";
      break;
    default:
      break;
  }
  return {
      {"state", "found"},
      {"instruments", in.instruments},
      {"tip_voxel", {number(in.tip_voxel[0]), number(in.tip_voxel[1]), number(in.tip_voxel[2])}},
      {"tip_um", {number(in.tip_um[0]), number(in.tip_um[1]), number(in.tip_um[2])}},
      {"to_ilm_um", number(in.to_ilm_um)},
      {"to_rpe_um", number(in.to_rpe_um)},
      {"distance", source},
      {"translucent", in.translucent != 0},
      {"warning", in.warning != 0},
      {"warn_rpe_um", number(in.warn_rpe_um)},
      {"render_xy",
       {{number(in.render_x[0]), number(in.render_y[0])},
        {number(in.render_x[1]), number(in.render_y[1])}}}};
}

}  // namespace

FrameMessage make_frame_message(const shm::Frame& frame, std::uint64_t now_ns,
                                std::uint64_t pictures, bool pictures_new) {
  const shm::FrameMeta& m = frame.meta;
  nlohmann::json description = {
      {"type", "frame"},
      {"frame", m.frame_index},
      {"view", m.view_id},
      {"group", m.group_index},
      {"volume", m.volume_index},
      {"generation", m.params_generation},
      {"mode", std::string(m.mode)},
      {"width", m.width},
      {"height", m.height},
      {"stereo", m.stereo != 0},
      {"render_bytes", m.render_bytes},
      {"bscan_bytes", m.bscan_bytes},
      {"bscan_index", m.bscan_index},
      {"bscans", m.bscans},
      {"bscan_width", m.bscan_width},
      {"bscan_height", m.bscan_height},
      {"instrument", instrument_json(m.instrument)},
      {"tip_bscans_bytes", m.tip_bscans_bytes},
      {"tip_bscan_width", m.tip_bscan_width},
      {"tip_bscan_height", m.tip_bscan_height},
      {"pictures", pictures},
      // CLOCK_MONOTONIC, for clients on this machine: the group published by ioct-rt, placed in
      // the live volume, its frame rendered and written to the frame ring by ioct-gpu, and this
      // message made by ioct-view (so a client can tell where a frame's age comes from).
      {"published_ns", m.t_group_published_ns},
      {"processed_ns", m.t_group_processed_ns},
      {"rendered_ns", m.t_rendered_ns},
      {"written_ns", m.t_written_ns},
      {"made_ns", now_ns},
      {"age_ms", ms_between(m.t_group_published_ns, now_ns)},
      {"published_to_rendered_ms", ms_between(m.t_group_published_ns, m.t_rendered_ns)},
      {"published_to_sent_ms", ms_between(m.t_group_published_ns, now_ns)}};
  const auto message = [&](std::size_t payload_bytes) {
    const std::string json = description.dump();
    auto bytes = std::make_shared<std::string>();
    bytes->reserve(4 + json.size() + payload_bytes);
    const auto n = static_cast<std::uint32_t>(json.size());
    for (int i = 0; i < 4; ++i) bytes->push_back(static_cast<char>((n >> (8 * i)) & 0xff));
    bytes->append(json);
    bytes->append(reinterpret_cast<const char*>(frame.payload.data()), payload_bytes);
    return bytes;
  };
  FrameMessage out{
      message(frame.payload.size()), nullptr, pictures, m.frame_index, m.view_id, m.group_index,
      m.t_group_published_ns};
  if (!pictures_new && (m.bscan_bytes != 0 || m.tip_bscans_bytes != 0)) {
    description["bscan_bytes"] = 0;
    description["tip_bscans_bytes"] = 0;
    description["pictures_repeated"] = true;
    out.without_pictures = message(std::min<std::size_t>(m.render_bytes, frame.payload.size()));
  }
  return out;
}

}  // namespace ioct::view
