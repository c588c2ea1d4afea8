#include <algorithm>
#include <stdexcept>

#include "cuda_kernels.cuh"
#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/processing/cuda_oct_processor.hpp"
#include "ioct/gpu/processing/group_check.hpp"
#include "ioct/gpu/processing/repeats.hpp"
#include "ioct/gpu/processing/spectral_tables.hpp"

namespace ioct::gpu {

static_assert(sizeof(std::complex<float>) == sizeof(float2));

struct CudaOctProcessor::Impl {
  explicit Impl(const OctProcessorConfig& c) : config(c) {}
  ~Impl() { destroy_plan(); }

  void destroy_plan() {
    if (has_plan) cufftDestroy(plan);
    has_plan = false;
  }

  OctProcessorConfig config;
  cuda::Stream stream;
  std::optional<shm::RingGeometry> geometry;
  std::optional<SpectralTables> tables;
  std::uint32_t spectra_distance = 0;  // elements between rows of the FFT input
  std::uint32_t bins_distance = 0;     // float2 between rows of the FFT output
  cuda::DeviceArray<float> window;
  cuda::DeviceArray<float> background;
  cuda::DeviceArray<float> windowed_background;
  cuda::DeviceArray<std::uint32_t> taps_first;
  cuda::DeviceArray<float> taps_weights;
  cuda::DeviceArray<float2> correction;
  cuda::DeviceArray<unsigned long long> group_sums;
  cuda::DeviceArray<unsigned long long> history;  // [slot][sample]
  RollingSums counts;                             // the history's A-scan counts (host side)
  cuda::DeviceArray<float> real_spectra;
  cuda::DeviceArray<float2> complex_spectra;  // with dispersion; also the FFT output (in place)
  cuda::DeviceArray<float2> bins;             // real-to-complex output
  cufftHandle plan = 0;
  bool has_plan = false;
  // process(): the group and its pixels on the device.
  cuda::DeviceArray<std::uint16_t> raw;
  cuda::DeviceArray<std::uint8_t> pixels;

  const float2* fft_output() const {
    return tables->complex_fft() ? complex_spectra.data() : bins.data();
  }
  cuda::DeviceTaps taps() const {
    return {tables->resampling.taps, taps_first.data(), taps_weights.data()};
  }
};

namespace {

template <class T>
cuda::DeviceArray<T> upload(const T* values, std::size_t count, cudaStream_t stream) {
  cuda::DeviceArray<T> array(count);
  if (count > 0) {
    IOCT_CUDA_CHECK(
        cudaMemcpyAsync(array.data(), values, count * sizeof(T), cudaMemcpyHostToDevice, stream));
  }
  return array;
}

}  // namespace

CudaOctProcessor::CudaOctProcessor(const OctProcessorConfig& config) {
  config.validate();
  if (const std::optional<std::string> problem = cuda_device_problem()) {
    throw BackendUnavailable("backend cuda: " + *problem);
  }
  impl_ = std::make_unique<Impl>(config);
}

CudaOctProcessor::~CudaOctProcessor() {
  if (impl_) cudaStreamSynchronize(impl_->stream.get());  // nothing may still use the buffers
}

CUstream_st* CudaOctProcessor::stream() const noexcept {
  return impl_->stream.get();
}

std::uint32_t CudaOctProcessor::depth() const noexcept {
  return impl_->tables ? impl_->tables->depth : 0;
}

void CudaOctProcessor::set_db_range(const DbScaleConfig& scale) {
  Impl& m = *impl_;
  scale.validate();
  if (m.tables) m.tables->set_db_range(scale);  // the gain and offset are launch arguments
  m.config.scale = scale;
}

void CudaOctProcessor::prepare(const shm::RingGeometry& geometry) {
  Impl& m = *impl_;
  IOCT_CUDA_CHECK(cudaStreamSynchronize(m.stream.get()));
  m.geometry.reset();  // unprepared until every buffer and plan below exists
  m.destroy_plan();
  require_processable(geometry);
  m.config.validate_for(geometry);
  const std::uint32_t samples = geometry.samples_per_ascan;
  m.tables.emplace(make_spectral_tables(m.config, samples));
  const SpectralTables& t = *m.tables;
  const cudaStream_t s = m.stream.get();
  const std::size_t max_rows = std::size_t{geometry.bscans_per_group} * geometry.ascans_per_bscan;

  m.window = upload(t.window.data(), samples, s);
  m.taps_first = upload(t.resampling.first.data(), t.resampling.first.size(), s);
  m.taps_weights = upload(t.resampling.weights.data(), t.resampling.weights.size(), s);
  m.correction =
      upload(reinterpret_cast<const float2*>(t.correction.data()), t.correction.size(), s);
  m.background = cuda::DeviceArray<float>(samples);
  m.windowed_background = cuda::DeviceArray<float>(samples);
  IOCT_CUDA_CHECK(cudaMemsetAsync(m.background.data(), 0, m.background.bytes(), s));
  IOCT_CUDA_CHECK(
      cudaMemsetAsync(m.windowed_background.data(), 0, m.windowed_background.bytes(), s));
  const std::uint32_t slots =
      m.config.background.mode == BackgroundMode::none ? 1 : m.config.background.groups;
  m.counts.reset(slots, 0);
  m.group_sums = cuda::DeviceArray<unsigned long long>(samples);
  m.history = cuda::DeviceArray<unsigned long long>(std::size_t{slots} * samples);
  IOCT_CUDA_CHECK(cudaMemsetAsync(m.history.data(), 0, m.history.bytes(), s));

  // One plan over every record a group can hold; rows the group does not fill are transformed
  // too (they hold finite leftovers), which keeps the plan fixed from prepare() on.
  const int n[1] = {static_cast<int>(samples)};
  m.real_spectra = {};
  m.complex_spectra = {};
  m.bins = {};
  if (t.complex_fft()) {
    m.spectra_distance = samples;
    m.bins_distance = samples;
    m.complex_spectra = cuda::DeviceArray<float2>(max_rows * samples);
    IOCT_CUDA_CHECK(cudaMemsetAsync(m.complex_spectra.data(), 0, m.complex_spectra.bytes(), s));
    int embed[1] = {static_cast<int>(samples)};
    IOCT_CUDA_CHECK(cufftPlanMany(&m.plan, 1, const_cast<int*>(n), embed, 1, embed[0], embed, 1,
                                  embed[0], CUFFT_C2C, static_cast<int>(max_rows)));
  } else {
    m.spectra_distance = samples;
    m.bins_distance = samples / 2 + 1;
    m.real_spectra = cuda::DeviceArray<float>(max_rows * samples);
    m.bins = cuda::DeviceArray<float2>(max_rows * m.bins_distance);
    IOCT_CUDA_CHECK(cudaMemsetAsync(m.real_spectra.data(), 0, m.real_spectra.bytes(), s));
    int in_embed[1] = {static_cast<int>(samples)};
    int out_embed[1] = {static_cast<int>(m.bins_distance)};
    IOCT_CUDA_CHECK(cufftPlanMany(&m.plan, 1, const_cast<int*>(n), in_embed, 1, in_embed[0],
                                  out_embed, 1, out_embed[0], CUFFT_R2C,
                                  static_cast<int>(max_rows)));
  }
  m.has_plan = true;
  IOCT_CUDA_CHECK(cufftSetStream(m.plan, s));
  m.raw = cuda::DeviceArray<std::uint16_t>(geometry.group_payload_bytes() / 2);
  m.pixels = cuda::DeviceArray<std::uint8_t>(max_rows * t.depth);
  IOCT_CUDA_CHECK(cudaStreamSynchronize(s));
  m.geometry = geometry;
}

void CudaOctProcessor::enqueue_transform(const shm::SlotHeader& header,
                                         const std::uint16_t* spectra, CUevent_st* ready) {
  Impl& m = *impl_;
  if (!m.geometry) throw std::logic_error("CudaOctProcessor used before prepare()");
  const SpectralTables& t = *m.tables;
  const cudaStream_t s = m.stream.get();
  const std::uint32_t width = header.active_ascan_end - header.active_ascan_begin;
  const cuda::RecordLayout layout{t.samples, m.geometry->ascans_per_bscan,
                                  header.active_ascan_begin, width, header.bscan_count * width};
  if (ready != nullptr) IOCT_CUDA_CHECK(cudaStreamWaitEvent(s, ready, 0));
  if (m.config.background.mode == BackgroundMode::rolling) {
    IOCT_CUDA_CHECK(cudaMemsetAsync(m.group_sums.data(), 0, m.group_sums.bytes(), s));
    cuda::launch_sum_spectra(spectra, layout, m.group_sums.data(), s);
    const std::uint32_t slot = m.counts.push(layout.rows);
    cuda::launch_update_background(m.group_sums.data(), m.history.data(), slot,
                                   m.counts.used_slots(), m.counts.total_ascans(), t.samples,
                                   m.background.data(), s);
    cuda::launch_windowed_background(m.background.data(), m.taps(), m.window.data(), t.samples,
                                     m.windowed_background.data(), s);
  }
  cuda::launch_make_spectra(spectra, layout, m.taps(), m.window.data(),
                            m.windowed_background.data(),
                            t.complex_fft() ? m.correction.data() : nullptr, m.real_spectra.data(),
                            m.complex_spectra.data(), m.spectra_distance, s);
  if (t.complex_fft()) {
    IOCT_CUDA_CHECK(cufftExecC2C(m.plan, reinterpret_cast<cufftComplex*>(m.complex_spectra.data()),
                                 reinterpret_cast<cufftComplex*>(m.complex_spectra.data()),
                                 CUFFT_FORWARD));
  } else {
    IOCT_CUDA_CHECK(cufftExecR2C(m.plan, m.real_spectra.data(),
                                 reinterpret_cast<cufftComplex*>(m.bins.data())));
  }
}

void CudaOctProcessor::enqueue_pixels(const shm::SlotHeader& header, std::uint32_t first,
                                      std::uint32_t last, const DevicePixelTarget& target) {
  Impl& m = *impl_;
  if (!m.geometry) throw std::logic_error("CudaOctProcessor used before prepare()");
  const std::uint32_t repeats = m.config.repeats_per_position;
  const std::uint32_t outputs = header.bscan_count / repeats;
  if (first >= last || last > outputs) return;
  cuda::PixelJob job{};
  job.first = first;
  job.count = last - first;
  job.repeats = repeats;
  for (std::uint32_t b = 0; b < header.bscan_count; ++b) {
    if ((header.bscans[b].flags & shm::kBscanReversed) != 0) job.reversed_mask |= 1ull << b;
  }
  std::copy(target.position.begin(), target.position.end(), job.position);
  const std::uint32_t width = header.active_ascan_end - header.active_ascan_begin;
  const SpectralTables& t = *m.tables;
  cuda::launch_log_u8(m.fft_output(), m.bins_distance, width, t.depth, job, t.scale.gain(),
                      t.scale.offset(), target.pixels, m.stream.get());
}

void CudaOctProcessor::process(const RawGroup& group, ProcessedGroup& out) {
  Impl& m = *impl_;
  if (!m.geometry) throw std::logic_error("CudaOctProcessor::process before prepare()");
  const shm::RingGeometry& g = *m.geometry;
  const std::uint32_t repeats = m.config.repeats_per_position;
  if (auto problem = find_group_problem(group.header, g, group.spectra.size_bytes(), repeats)) {
    throw std::invalid_argument("group " + std::to_string(group.header.group_index) + ": " +
                                *problem);
  }
  const shm::SlotHeader& h = group.header;
  const std::uint32_t width = h.active_ascan_end - h.active_ascan_begin;
  const cudaStream_t s = m.stream.get();
  IOCT_CUDA_CHECK(cudaMemcpyAsync(m.raw.data(), group.spectra.data(), g.group_payload_bytes(),
                                  cudaMemcpyHostToDevice, s));
  enqueue_transform(h, m.raw.data(), nullptr);
  out.group_index = h.group_index;
  out.producer_epoch = h.producer_epoch;
  out.t_publish_ns = h.t_publish_ns;
  out.bscan_count = h.bscan_count / repeats;
  out.ascans = width;
  out.depth = m.tables->depth;
  DevicePixelTarget target;
  target.pixels = m.pixels.data();
  target.position.fill(-1);
  for (std::uint32_t p = 0; p < out.bscan_count; ++p) {
    out.markers[p] = position_marker(h, p, repeats);
    target.position[p] = static_cast<std::int32_t>(p);
  }
  enqueue_pixels(h, 0, out.bscan_count, target);
  out.pixels.resize(std::size_t{out.bscan_count} * width * out.depth);
  IOCT_CUDA_CHECK(cudaMemcpyAsync(out.pixels.data(), m.pixels.data(), out.pixels.size(),
                                  cudaMemcpyDeviceToHost, s));
  IOCT_CUDA_CHECK(cudaStreamSynchronize(s));
}

std::vector<float> CudaOctProcessor::last_background() const {
  const Impl& m = *impl_;
  std::vector<float> values(m.background.size());
  IOCT_CUDA_CHECK(cudaStreamSynchronize(m.stream.get()));
  if (!values.empty()) {
    IOCT_CUDA_CHECK(cudaMemcpy(values.data(), m.background.data(), m.background.bytes(),
                               cudaMemcpyDeviceToHost));
  }
  return values;
}

}  // namespace ioct::gpu
