#include "ioct/gpu/offline/raw_processing.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/gpu/processing/group_check.hpp"
#include "ioct/gpu/volume/processed_group.hpp"
#include "ioct/gpu/volume/volume_assembler.hpp"
#include "ioct/shm/ring_layout.hpp"

namespace ioct::gpu::offline {
namespace {

// The slot header the producer would have written for B-scans [first, first + count) of the
// file's one volume.
void describe_group(shm::SlotHeader& header, std::uint64_t group_index, std::uint32_t first,
                    std::uint32_t count, const RawSpectraLayout& layout, bool bidirectional,
                    std::uint64_t payload_bytes) {
  header = shm::SlotHeader{};
  header.group_index = group_index;
  header.payload_bytes = payload_bytes;
  header.bscan_count = count;
  header.active_ascan_begin = 0;
  header.active_ascan_end = layout.ascans_per_bscan;
  for (std::uint32_t i = 0; i < count; ++i) {
    const std::uint32_t b = first + i;
    shm::BscanMarker& marker = header.bscans[i];
    marker.volume_index = 0;
    marker.bscan_in_volume = b;
    marker.flags = (b == 0 ? shm::kBscanVolumeStart : 0u) |
                   (b + 1 == layout.bscans ? shm::kBscanVolumeEnd : 0u) |
                   (bidirectional && b % 2 == 1 ? shm::kBscanReversed : 0u);
  }
}

}  // namespace

RawProcessingResult process_raw_file(const SpectraSource& file,
                                     const RawProcessingSettings& settings, ProgressBar* progress) {
  const RawSpectraLayout& layout = file.layout();
  require_integer_in_range("bscans_per_group", settings.bscans_per_group, 1,
                           shm::kMaxBscansPerGroup);
  shm::RingGeometry geometry;
  geometry.samples_per_ascan = layout.samples_per_ascan;
  geometry.ascans_per_bscan = layout.ascans_per_bscan;
  geometry.bscans_per_group = std::min(settings.bscans_per_group, layout.bscans);
  geometry.bscans_per_volume = layout.bscans;
  geometry.bytes_per_sample = 2;
  require_processable(geometry);
  settings.processing.validate_for(geometry);

  RawProcessingResult result;
  const std::unique_ptr<OctProcessor> processor =
      make_oct_processor(settings.backend, settings.processing);
  result.processor_backend = std::string(processor->backend_name());
  processor->prepare(geometry);

  // Whole groups even for a short last group: the chain reads a group's full payload.
  const std::uint64_t payload_bytes = geometry.group_payload_bytes();
  std::vector<std::uint16_t> spectra(payload_bytes / 2);
  ProcessedGroup processed;
  VolumeAssembler assembler(layout.bscans / settings.processing.repeats_per_position,
                            depth_of(geometry));
  bool completed = false;
  std::uint64_t group_index = 0;
  for (std::uint32_t first = 0; first < layout.bscans; first += geometry.bscans_per_group) {
    const std::uint32_t count = std::min(geometry.bscans_per_group, layout.bscans - first);
    file.read_bscans(first, count, spectra);
    shm::SlotHeader header;
    describe_group(header, group_index++, first, count, layout, settings.bidirectional,
                   payload_bytes);
    processor->process(RawGroup{header, spectra}, processed);
    assembler.place(processed, [&](const Volume& volume, const VolumeInfo& info) {
      if (!info.complete()) {
        throw std::runtime_error("the processing chain placed " +
                                 std::to_string(info.bscans_placed) + " of the file's B-scans, " +
                                 std::to_string(info.bscans_missing) + " missing");
      }
      result.volume = volume;
      completed = true;
    });
    if (progress != nullptr) progress->update(first + count);
  }
  if (!completed) throw std::runtime_error("the processing chain never completed the volume");

  if (settings.filter) {
    const auto filter = filters::make_volume_filter(settings.backend, *settings.filter,
                                                    settings.processing.threads);
    result.filter_backend = std::string(filter->backend_name());
    Volume filtered;
    filter->filter_volume(result.volume, filtered);
    result.volume = std::move(filtered);
  }
  if (progress != nullptr) progress->finish();
  return result;
}

}  // namespace ioct::gpu::offline
