#include "ioct/gpu/offline/ring_recording_volume.hpp"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <map>
#include <stdexcept>
#include <utility>

#include "ioct/gpu/offline/input_file_error.hpp"

namespace ioct::gpu::offline {
namespace {

constexpr char kHdf5Signature[8] = {'\x89', 'H', 'D', 'F', '\r', '\n', '\x1a', '\n'};

}  // namespace

bool is_hdf5_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  std::ifstream in(path, std::ios::binary);
  char head[8] = {};
  in.read(head, sizeof head);
  return in.gcount() == sizeof head && std::memcmp(head, kHdf5Signature, sizeof head) == 0;
}

RingRecordingVolume::RingRecordingVolume(const std::filesystem::path& path, std::uint64_t volume)
    : reader_(path), volume_(volume) {
  const shm::RingGeometry& g = reader_.geometry();
  if (g.bytes_per_sample != 2) {
    throw InputFileError(path, "holds samples of " + std::to_string(g.bytes_per_sample) +
                                   " bytes; offline processing reads 16-bit samples");
  }
  // Every volume the markers name, in the order they first appear, with where each B-scan is.
  struct Seen {
    std::vector<Place> places;
    std::vector<bool> present;
    std::uint32_t count = 0;
    bool reversed = false;
    std::uint32_t status = 0;
  };
  std::map<std::pair<std::uint64_t, std::uint64_t>, std::size_t> index;  // (epoch, volume)
  std::vector<Seen> volumes;
  shm::SlotHeader header{};
  for (std::uint64_t group = 0; group < reader_.group_count(); ++group) {
    reader_.read_header(group, header);
    if (header.bscan_count != g.bscans_per_group) {
      throw InputFileError(path, "group " + std::to_string(group) + ": slot header says " +
                                     std::to_string(header.bscan_count) +
                                     " B-scans, the geometry " +
                                     std::to_string(g.bscans_per_group));
    }
    for (std::uint32_t b = 0; b < header.bscan_count; ++b) {
      const shm::BscanMarker& marker = header.bscans[b];
      if (marker.bscan_in_volume >= g.bscans_per_volume) {
        throw InputFileError(path, "group " + std::to_string(group) + ", B-scan " +
                                       std::to_string(b) + ": bscan_in_volume " +
                                       std::to_string(marker.bscan_in_volume) + " of a volume of " +
                                       std::to_string(g.bscans_per_volume));
      }
      const auto key = std::make_pair(header.producer_epoch, marker.volume_index);
      auto [it, inserted] = index.try_emplace(key, volumes.size());
      if (inserted) {
        volumes.emplace_back();
        volumes.back().places.resize(g.bscans_per_volume);
        volumes.back().present.assign(g.bscans_per_volume, false);
      }
      Seen& seen = volumes[it->second];
      if (!seen.present[marker.bscan_in_volume]) {
        seen.present[marker.bscan_in_volume] = true;
        ++seen.count;
      }
      seen.places[marker.bscan_in_volume] = {group, b};
      seen.reversed = seen.reversed || (marker.flags & shm::kBscanReversed) != 0;
      seen.status |= header.status_flags;
    }
  }
  const Seen* chosen = nullptr;
  for (const Seen& seen : volumes) {
    if (seen.count != g.bscans_per_volume) continue;
    if (complete_volumes_ == volume) chosen = &seen;
    ++complete_volumes_;
  }
  if (chosen == nullptr) {
    throw InputFileError(path, "holds " + std::to_string(complete_volumes_) + " complete volume" +
                                   (complete_volumes_ == 1 ? "" : "s") + " (" +
                                   std::to_string(reader_.group_count()) + " groups, " +
                                   std::to_string(volumes.size()) + " volumes begun); volume " +
                                   std::to_string(volume) + " was asked for" +
                                   (reader_.finished() ? "" : " (the recording was never closed)"));
  }
  places_ = chosen->places;
  reversed_lines_ = chosen->reversed;
  status_seen_ = chosen->status;
  layout_.samples_per_ascan = g.samples_per_ascan;
  layout_.ascans_per_bscan = g.ascans_per_bscan;
  layout_.bscans = g.bscans_per_volume;
  layout_.validate();
  group_.resize(reader_.group_bytes());
}

void RingRecordingVolume::read_bscans(std::uint32_t first, std::uint32_t count,
                                      std::span<std::uint16_t> out) const {
  const std::size_t bscan_values =
      std::size_t{layout_.ascans_per_bscan} * layout_.samples_per_ascan;
  if (std::uint64_t{first} + count > layout_.bscans || out.size() < count * bscan_values) {
    throw std::out_of_range("RingRecordingVolume::read_bscans: B-scans [" + std::to_string(first) +
                            ", " + std::to_string(first + count) + ") of " +
                            std::to_string(layout_.bscans) + " into " + std::to_string(out.size()) +
                            " values");
  }
  for (std::uint32_t i = 0; i < count; ++i) {
    const Place& place = places_[first + i];
    if (place.group != group_loaded_) {
      shm::SlotHeader header{};
      reader_.read_group(place.group, group_, header);
      group_loaded_ = place.group;
    }
    std::memcpy(out.data() + i * bscan_values,
                group_.data() + place.bscan_in_group * bscan_values * sizeof(std::uint16_t),
                bscan_values * sizeof(std::uint16_t));
  }
}

std::string RingRecordingVolume::describe() const {
  return "volume " + std::to_string(volume_) + " of " + reader_.path().filename().string();
}

}  // namespace ioct::gpu::offline
