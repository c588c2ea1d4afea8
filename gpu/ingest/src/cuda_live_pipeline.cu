#include <algorithm>
#include <deque>
#include <limits>

#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/ingest/cuda_live_pipeline.hpp"
#include "ioct/gpu/processing/cuda_oct_processor.hpp"
#include "ioct/gpu/processing/group_check.hpp"
#include "ioct/gpu/processing/repeats.hpp"

namespace ioct::gpu {
namespace {

// The ring mapping registered with CUDA for as long as the pipeline lives: read-only if the
// device supports it, else with the default flags, else not at all (copies are then staged by
// the driver like pageable memory: correct, slower); `note` says which and why.
class HostRegistration {
 public:
  HostRegistration(const void* address, std::size_t bytes) : address_(const_cast<void*>(address)) {
    int device = 0;
    IOCT_CUDA_CHECK(cudaGetDevice(&device));
    int supported = 0;
    IOCT_CUDA_CHECK(cudaDeviceGetAttribute(&supported, cudaDevAttrHostRegisterSupported, device));
    if (supported == 0) {
      note_ = "not registered: the device does not support cudaHostRegister";
      return;
    }
    int read_only = 0;
    IOCT_CUDA_CHECK(
        cudaDeviceGetAttribute(&read_only, cudaDevAttrHostRegisterReadOnlySupported, device));
    if (read_only != 0) {
      const cudaError_t status = cudaHostRegister(address_, bytes, cudaHostRegisterReadOnly);
      if (status == cudaSuccess) {
        registered_ = true;
        note_ = "registered read-only (cudaHostRegisterReadOnly)";
        return;
      }
      cudaGetLastError();
      note_ = "cudaHostRegister(cudaHostRegisterReadOnly) failed: " + cuda::describe(status) + "; ";
    } else {
      note_ = "the device does not support cudaHostRegisterReadOnly; ";
    }
    const cudaError_t status = cudaHostRegister(address_, bytes, cudaHostRegisterDefault);
    if (status == cudaSuccess) {
      registered_ = true;
      note_ += "registered with the default flags";
      return;
    }
    cudaGetLastError();
    note_ += "cudaHostRegister(default) failed too: " + cuda::describe(status) +
             "; copies are staged like pageable memory";
  }
  ~HostRegistration() {
    if (registered_) cudaHostUnregister(address_);
  }
  HostRegistration(const HostRegistration&) = delete;
  HostRegistration& operator=(const HostRegistration&) = delete;
  const std::string& note() const noexcept { return note_; }

 private:
  void* address_;
  bool registered_ = false;
  std::string note_;
};

// Host volumes for completed volumes' copies, their memory registered with CUDA so the copy from
// the device lands in them directly (no staging, no second copy). Reused; a new one is made only
// when all are taken (a volume is taken from its copy until it has been handed out).
class HostVolumePool {
 public:
  HostVolumePool() = default;
  HostVolumePool(const HostVolumePool&) = delete;
  HostVolumePool& operator=(const HostVolumePool&) = delete;
  ~HostVolumePool() {
    for (Entry& e : entries_) unregister(e);
  }

  std::uint32_t acquire(std::uint32_t bscans, std::uint32_t ascans, std::uint32_t depth) {
    auto it =
        std::find_if(entries_.begin(), entries_.end(), [](const Entry& e) { return !e.taken; });
    if (it == entries_.end()) it = entries_.emplace(entries_.end());
    Entry& e = *it;
    e.volume.reshape(bscans, ascans, depth);
    const std::span<std::uint8_t> pixels = e.volume.pixels();
    if (pixels.data() != e.registered || pixels.size() != e.bytes) {
      unregister(e);
      IOCT_CUDA_CHECK(cudaHostRegister(pixels.data(), pixels.size(), cudaHostRegisterDefault));
      e.registered = pixels.data();
      e.bytes = pixels.size();
    }
    e.taken = true;
    return static_cast<std::uint32_t>(it - entries_.begin());
  }
  void release(std::uint32_t index) noexcept { entries_[index].taken = false; }
  Volume& volume(std::uint32_t index) noexcept { return entries_[index].volume; }

 private:
  struct Entry {
    Volume volume;
    void* registered = nullptr;
    std::size_t bytes = 0;
    bool taken = false;
  };
  static void unregister(Entry& e) noexcept {
    if (e.registered != nullptr) cudaHostUnregister(e.registered);
    e.registered = nullptr;
    e.bytes = 0;
  }

  std::deque<Entry> entries_;
};

}  // namespace

struct CudaLivePipeline::Impl {
  struct Buffer {
    cuda::DeviceArray<std::uint16_t> raw;
    cuda::Event copied;
    bool busy = false;
  };
  struct Copy {
    shm::ReadTicket ticket;
    std::uint32_t buffer = 0;
  };
  struct Snapshot {
    std::uint32_t volume = 0;  // in the host volume pool
    VolumeInfo info;
    cuda::Event copied;  // on the snapshot stream
  };
  // A group whose processing is enqueued, until its last write has landed.
  struct Landing {
    shm::SlotHeader header{};
    std::uint32_t buffer = 0;
    cuda::Event landed;
    PlacementResult placed;
    std::vector<Snapshot> snapshots;
  };

  // The pixel side of VolumeBook: kernel launches and memsets on the processing stream.
  class DevicePixels final : public VolumeBook::Pixels {
   public:
    DevicePixels(Impl& m, const shm::SlotHeader* header, Landing& landing, bool snapshots)
        : m_(m), header_(header), landing_(landing), snapshots_(snapshots) {
      target_.position.fill(-1);
    }
    void begin(std::uint32_t ascans) override {
      flush();
      m_.volume_ascans = ascans;
    }
    void place(std::uint32_t source, std::uint32_t position) override {
      target_.position[source] = static_cast<std::int32_t>(position);
      first_ = std::min(first_, source);
      end_ = source + 1;
    }
    void finish(const VolumeInfo& info, const std::vector<bool>& placed) override {
      flush();
      m_.zero_missing(placed);
      if (snapshots_) m_.snapshot(info, landing_);
    }
    void flush() {
      if (header_ == nullptr || end_ == 0) return;
      m_.after_snapshot();
      target_.pixels = m_.volume.data();
      m_.processor.enqueue_pixels(*header_, first_, end_, target_);
      target_.position.fill(-1);
      first_ = std::numeric_limits<std::uint32_t>::max();
      end_ = 0;
    }

   private:
    Impl& m_;
    const shm::SlotHeader* header_;
    Landing& landing_;
    bool snapshots_;
    DevicePixelTarget target_;
    std::uint32_t first_ = std::numeric_limits<std::uint32_t>::max();
    std::uint32_t end_ = 0;
  };

  Impl(const OctProcessorConfig& c, shm::RingReader r, const LivePipelineOptions& o)
      : config(c),
        options(o),
        reader(std::move(r)),
        geometry(reader.geometry()),
        repeats(c.repeats_per_position),
        processor(c),
        registration(reader.mapping(), reader.mapping_bytes()),
        book(geometry.bscans_per_volume / std::max(1u, c.repeats_per_position)) {
    if (options.groups_in_flight < 2) {
      throw std::invalid_argument("CudaLivePipeline: groups_in_flight = " +
                                  std::to_string(options.groups_in_flight) + ", at least 2");
    }
    processor.prepare(geometry);
    depth = processor.depth();
    const std::uint64_t payload = reader.layout().group_payload_bytes;
    for (std::uint32_t i = 0; i < options.groups_in_flight; ++i) {
      buffers.push_back(Buffer{cuda::DeviceArray<std::uint16_t>((payload + 1) / 2), {}, false});
    }
    volume = cuda::DeviceArray<std::uint8_t>(std::size_t{book.positions()} *
                                             geometry.ascans_per_bscan * depth);
    IOCT_CUDA_CHECK(cudaMemsetAsync(volume.data(), 0, volume.bytes(), processor.stream()));
    IOCT_CUDA_CHECK(cudaStreamSynchronize(processor.stream()));
  }

  ~Impl() {
    cudaStreamSynchronize(copy_stream.get());
    cudaStreamSynchronize(processor.stream());
    cudaStreamSynchronize(snapshot_stream.get());
  }

  std::size_t bscan_bytes() const { return std::size_t{volume_ascans} * depth; }

  // The volume is about to be written on the processing stream: after the last volume's host copy
  // has read it (the transform before it overlaps the copy; only the writes wait).
  void after_snapshot() {
    if (!snapshot_pending) return;
    IOCT_CUDA_CHECK(cudaStreamWaitEvent(processor.stream(), snapshot_read.get(), 0));
    snapshot_pending = false;
  }

  void zero_missing(const std::vector<bool>& placed) {
    after_snapshot();
    const std::size_t stride = bscan_bytes();
    for (std::uint32_t p = 0; p < placed.size();) {
      if (placed[p]) {
        ++p;
        continue;
      }
      std::uint32_t end = p;
      while (end < placed.size() && !placed[end]) ++end;
      IOCT_CUDA_CHECK(
          cudaMemsetAsync(volume.data() + p * stride, 0, (end - p) * stride, processor.stream()));
      p = end;
    }
  }

  // Copies the volume as it is now to a host volume, on a stream of its own: the group that
  // completed the volume lands (and goes to the stages) without waiting for the whole volume to
  // cross the bus (45 MB, about 0.9 ms, at the default geometry); the next writes into the volume
  // wait for the copy instead (after_snapshot()), so nothing overwrites what it reads.
  void snapshot(const VolumeInfo& info, Landing& landing) {
    const std::uint32_t index = host_volumes.acquire(book.positions(), volume_ascans, depth);
    const std::span<std::uint8_t> pixels = host_volumes.volume(index).pixels();
    IOCT_CUDA_CHECK(cudaEventRecord(volume_placed.get(), processor.stream()));
    IOCT_CUDA_CHECK(cudaStreamWaitEvent(snapshot_stream.get(), volume_placed.get(), 0));
    IOCT_CUDA_CHECK(cudaMemcpyAsync(pixels.data(), volume.data(), pixels.size(),
                                    cudaMemcpyDeviceToHost, snapshot_stream.get()));
    Snapshot& s = landing.snapshots.emplace_back();
    s.volume = index;
    s.info = info;
    IOCT_CUDA_CHECK(cudaEventRecord(s.copied.get(), snapshot_stream.get()));
    IOCT_CUDA_CHECK(cudaEventRecord(snapshot_read.get(), snapshot_stream.get()));
    snapshot_pending = true;
  }

  void deliver(const Snapshot& s, LiveEvents& events) {
    events.on_volume(host_volumes.volume(s.volume), s.info);
    host_volumes.release(s.volume);
  }

  // Reports the groups whose processing has completed, in order, and then the volumes they
  // completed whose host copies have landed: the stages take a group before the volume's host
  // copy is turned into images (tens of ms on the CPU, 1 group in 8).
  bool retire(LiveEvents& events) {
    bool any = false;
    while (!landing.empty() && landing.front().landed.done()) {
      Landing& l = landing.front();
      buffers[l.buffer].busy = false;
      events.on_group(l.header, l.placed);
      for (Snapshot& s : l.snapshots) copied_snapshots.push_back(std::move(s));
      landing.pop_front();
      any = true;
    }
    while (!copied_snapshots.empty() && copied_snapshots.front().copied.done()) {
      deliver(copied_snapshots.front(), events);
      copied_snapshots.pop_front();
      any = true;
    }
    return any;
  }

  // Starts copying the next group into a free buffer. ready: a copy is under way (or no buffer
  // is free yet); otherwise what begin_read() said.
  shm::PollStatus start_copy() {
    if (copying) return shm::PollStatus::ready;
    const auto free =
        std::find_if(buffers.begin(), buffers.end(), [](const Buffer& b) { return !b.busy; });
    if (free == buffers.end()) return shm::PollStatus::ready;
    shm::ReadTicket ticket;
    const shm::PollStatus status = reader.begin_read(ticket);
    if (status != shm::PollStatus::ready) return status;
    free->busy = true;
    IOCT_CUDA_CHECK(cudaMemcpyAsync(free->raw.data(), ticket.payload, ticket.payload_bytes,
                                    cudaMemcpyHostToDevice, copy_stream.get()));
    IOCT_CUDA_CHECK(cudaEventRecord(free->copied.get(), copy_stream.get()));
    copying = Copy{ticket, static_cast<std::uint32_t>(free - buffers.begin())};
    return shm::PollStatus::ready;
  }

  // The copy in flight has completed: verify it, keep the copy engine busy, process.
  void finish_copy(LiveEvents& events, bool start_next) {
    const Copy copy = *copying;
    copying.reset();
    if (!reader.end_read(copy.ticket)) {  // lapped while copying: counted by the reader
      buffers[copy.buffer].busy = false;
      return;
    }
    if (start_next) start_copy();
    process(copy.ticket.header, copy.buffer, events);
  }

  void process(const shm::SlotHeader& header, std::uint32_t buffer, LiveEvents& events) {
    if (last_epoch && *last_epoch != header.producer_epoch) events.on_restart(book.reset());
    last_epoch = header.producer_epoch;
    if (auto problem =
            find_group_problem(header, geometry, reader.layout().group_payload_bytes, repeats)) {
      buffers[buffer].busy = false;
      events.on_rejected(header, *problem);
      return;
    }
    const cudaStream_t s = processor.stream();
    if (reads_pending) {  // the volume is about to be written: readers first
      IOCT_CUDA_CHECK(cudaStreamWaitEvent(s, reads_done.get(), 0));
      reads_pending = false;
    }
    processor.enqueue_transform(header, buffers[buffer].raw.data(), buffers[buffer].copied.get());
    landing.emplace_back();
    Landing& l = landing.back();
    l.header = header;
    l.buffer = buffer;
    const std::uint32_t outputs = header.bscan_count / repeats;
    std::array<shm::BscanMarker, shm::kMaxBscansPerGroup> markers{};
    for (std::uint32_t p = 0; p < outputs; ++p) markers[p] = position_marker(header, p, repeats);
    DevicePixels pixels(*this, &l.header, l, options.host_volumes);
    const std::uint32_t width = header.active_ascan_end - header.active_ascan_begin;
    l.placed = book.place(std::span(markers.data(), outputs), width, header.group_index, pixels);
    pixels.flush();
    IOCT_CUDA_CHECK(cudaEventRecord(l.landed.get(), s));
    ++version;
  }

  OctProcessorConfig config;
  LivePipelineOptions options;
  shm::RingReader reader;
  shm::RingGeometry geometry;
  std::uint32_t repeats;
  CudaOctProcessor processor;
  HostRegistration registration;
  cuda::Stream copy_stream;
  std::vector<Buffer> buffers;
  std::optional<Copy> copying;
  std::deque<Landing> landing;
  std::uint32_t depth = 0;
  VolumeBook book;
  cuda::DeviceArray<std::uint8_t> volume;  // positions x ascans_per_bscan x depth, the width used
  std::uint32_t volume_ascans = 0;
  HostVolumePool host_volumes;
  std::optional<std::uint32_t> sealed;  // the host volume seal_partial() returned
  cuda::Stream readback_stream;         // copy_bscans()
  cuda::Event reads_done;
  bool reads_pending = false;
  cuda::Stream snapshot_stream;  // completed volumes' host copies
  cuda::Event volume_placed;     // the copy waits for the volume's last placement
  cuda::Event snapshot_read;     // the next group's writes wait for the copy
  bool snapshot_pending = false;
  std::deque<Snapshot> copied_snapshots;  // their groups reported, their copies under way
  std::uint64_t version = 0;
  std::optional<std::uint64_t> last_epoch;
};

CudaLivePipeline::CudaLivePipeline(const OctProcessorConfig& config, shm::RingReader reader,
                                   const LivePipelineOptions& options)
    : impl_(std::make_unique<Impl>(config, std::move(reader), options)) {}

CudaLivePipeline::~CudaLivePipeline() = default;

const shm::RingReader& CudaLivePipeline::reader() const noexcept {
  return impl_->reader;
}

void CudaLivePipeline::set_db_range(const DbScaleConfig& scale) {
  impl_->processor.set_db_range(scale);
}

const std::string& CudaLivePipeline::ingest_note() const noexcept {
  return impl_->registration.note();
}

shm::PollStatus CudaLivePipeline::poll(LiveEvents& events) {
  Impl& m = *impl_;
  bool progressed = m.retire(events);
  if (m.copying) {
    if (!m.buffers[m.copying->buffer].copied.done()) return shm::PollStatus::ready;
    m.finish_copy(events, true);
    progressed = true;
  }
  const shm::PollStatus status = m.start_copy();
  if (status == shm::PollStatus::producer_gone) {
    return m.landing.empty() && !m.copying ? shm::PollStatus::producer_gone
                                           : shm::PollStatus::ready;
  }
  if (status == shm::PollStatus::lapped || m.copying || progressed || !m.landing.empty()) {
    return shm::PollStatus::ready;
  }
  return status;  // empty
}

void CudaLivePipeline::drain(LiveEvents& events) {
  Impl& m = *impl_;
  while (m.copying) {
    IOCT_CUDA_CHECK(cudaEventSynchronize(m.buffers[m.copying->buffer].copied.get()));
    m.finish_copy(events, false);
  }
  IOCT_CUDA_CHECK(cudaStreamSynchronize(m.processor.stream()));
  IOCT_CUDA_CHECK(cudaStreamSynchronize(m.snapshot_stream.get()));
  m.retire(events);
}

std::optional<VolumeInfo> CudaLivePipeline::seal_partial(const Volume*& volume) {
  Impl& m = *impl_;
  volume = nullptr;
  Impl::Landing sealed;
  Impl::DevicePixels pixels(m, nullptr, sealed, true);
  const std::optional<VolumeInfo> info = m.book.seal_partial(pixels);
  if (!info) return std::nullopt;
  IOCT_CUDA_CHECK(cudaEventSynchronize(sealed.snapshots.front().copied.get()));
  if (m.sealed) m.host_volumes.release(*m.sealed);
  m.sealed = sealed.snapshots.front().volume;  // kept until the next call
  volume = &m.host_volumes.volume(*m.sealed);
  return info;
}

void CudaLivePipeline::read_volume(
    CUstream_st* stream, const std::function<void(const DeviceVolumeView&)>& enqueue_reads) {
  Impl& m = *impl_;
  if (!m.landing.empty()) {
    IOCT_CUDA_CHECK(cudaStreamWaitEvent(stream, m.landing.back().landed.get(), 0));
  }
  if (m.reads_pending) IOCT_CUDA_CHECK(cudaStreamWaitEvent(stream, m.reads_done.get(), 0));
  enqueue_reads(
      DeviceVolumeView{m.volume.data(), m.book.positions(), m.volume_ascans, m.depth, m.version});
  IOCT_CUDA_CHECK(cudaEventRecord(m.reads_done.get(), stream));
  m.reads_pending = true;
}

bool CudaLivePipeline::read_on_device(
    CUstream_st* stream, const std::function<void(const DeviceVolumeView&)>& enqueue_reads) {
  read_volume(stream, enqueue_reads);
  return true;
}

LiveVolumeShape CudaLivePipeline::shape() const {
  const Impl& m = *impl_;
  if (m.volume_ascans == 0) return {};  // no volume begun
  return {m.book.positions(), m.volume_ascans, m.depth};
}

void CudaLivePipeline::copy_bscans(std::uint32_t first, std::uint32_t count, Volume& out) {
  Impl& m = *impl_;
  prepare_bscan_copy(shape(), first, count, out);
  if (count == 0) return;
  cudaStream_t stream = m.readback_stream.get();
  read_volume(stream, [&](const DeviceVolumeView& view) {
    const std::size_t stride = std::size_t{view.ascans} * view.depth;
    cuda::copy_async(out.bscan(first).data(), view.pixels + first * stride, count * stride,
                     cudaMemcpyDeviceToHost, stream, cuda::Payload::volume,
                     "copy of live B-scans to the host");
  });
  IOCT_CUDA_CHECK(cudaStreamSynchronize(stream));
}

}  // namespace ioct::gpu
