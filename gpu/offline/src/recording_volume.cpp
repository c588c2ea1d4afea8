#include "ioct/gpu/offline/recording_volume.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "ioct/gpu/offline/input_file_error.hpp"

namespace ioct::gpu::offline {

std::uint64_t RecordingVolume::volume_count(const recording::RecordingReader& reader) noexcept {
  const recording::RecordingGeometry& g = reader.geometry();
  return reader.group_count() * g.bscans_per_group / g.bscans_per_volume;
}

RecordingVolume::RecordingVolume(const std::filesystem::path& path, std::uint64_t volume)
    : reader_(path), volume_(volume) {
  const std::uint64_t volumes = volume_count(reader_);
  if (volume >= volumes) {
    throw InputFileError(
        reader_.raw_path(),
        "holds " + std::to_string(volumes) + " whole volume" + (volumes == 1 ? "" : "s") + " (" +
            std::to_string(reader_.group_count()) + " groups of " +
            std::to_string(reader_.geometry().bscans_per_group) + " B-scans, " +
            std::to_string(reader_.geometry().bscans_per_volume) + " B-scans per volume); volume " +
            std::to_string(volume) + " was asked for" +
            (reader_.complete() ? "" : " (the recording was never closed)"));
  }
  const recording::RecordingGeometry& g = reader_.geometry();
  layout_.samples_per_ascan = g.samples_per_ascan;
  layout_.ascans_per_bscan = g.ascans_per_bscan;
  layout_.bscans = g.bscans_per_volume;
  layout_.validate();
  group_.resize(g.samples_per_group());
}

void RecordingVolume::read_bscans(std::uint32_t first, std::uint32_t count,
                                  std::span<std::uint16_t> out) const {
  const recording::RecordingGeometry& g = reader_.geometry();
  const std::size_t bscan_values = std::size_t{g.ascans_per_bscan} * g.samples_per_ascan;
  if (std::uint64_t{first} + count > layout_.bscans || out.size() < count * bscan_values) {
    throw std::out_of_range("RecordingVolume::read_bscans: B-scans [" + std::to_string(first) +
                            ", " + std::to_string(first + count) + ") of " +
                            std::to_string(layout_.bscans) + " into " + std::to_string(out.size()) +
                            " values");
  }
  for (std::uint32_t i = 0; i < count; ++i) {
    // B-scans are numbered through the whole recording; each group holds bscans_per_group of them.
    const std::uint64_t bscan = volume_ * g.bscans_per_volume + first + i;
    const std::uint64_t group = bscan / g.bscans_per_group;
    if (group != group_loaded_) {
      recording::RecordedGroupInfo info;
      reader_.read_group(group, group_, info);
      group_loaded_ = group;
      status_seen_ |= info.status;
    }
    const std::size_t offset = (bscan % g.bscans_per_group) * bscan_values;
    std::copy_n(group_.begin() + static_cast<std::ptrdiff_t>(offset), bscan_values,
                out.begin() + static_cast<std::ptrdiff_t>(i * bscan_values));
  }
}

std::string RecordingVolume::describe() const {
  return "volume " + std::to_string(volume_) + " of " + reader_.json_path().stem().string();
}

RecordingProcessingHints RecordingVolume::processing_hints() const {
  const recording::RecordingMetadata& m = reader_.metadata();
  RecordingProcessingHints hints;
  hints.resampling_coefficients = m.resampling_coefficients;
  hints.dispersion_c2 = m.dispersion_c2;
  hints.dispersion_c3 = m.dispersion_c3;
  hints.bidirectional = m.scan.bidirectional;
  hints.bscans_per_group = m.geometry.bscans_per_group;
  return hints;
}

}  // namespace ioct::gpu::offline
