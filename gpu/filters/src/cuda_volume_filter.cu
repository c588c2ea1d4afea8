#include "ioct/gpu/filters/cuda_volume_filter.hpp"

#include <stdexcept>
#include <string>
#include <utility>

#include "filter_kernels_probe.hpp"

namespace ioct::gpu::filters {

void check_cuda(cudaError_t status, const char* what) {
  if (status != cudaSuccess) {
    throw std::runtime_error(std::string("CUDA: ") + what + " failed: " + cudaGetErrorName(status) +
                             " (" + cudaGetErrorString(status) + ")");
  }
}

DeviceBytes::DeviceBytes(std::size_t bytes) : size_(bytes) {
  void* pointer = nullptr;
  check_cuda(cudaMalloc(&pointer, bytes),
             ("cudaMalloc of " + std::to_string(bytes) + " bytes").c_str());
  data_ = static_cast<std::uint8_t*>(pointer);
}

DeviceBytes::DeviceBytes(DeviceBytes&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)) {}

DeviceBytes& DeviceBytes::operator=(DeviceBytes&& other) noexcept {
  if (this != &other) {
    if (data_ != nullptr) cudaFree(data_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
  }
  return *this;
}

DeviceBytes::~DeviceBytes() {
  if (data_ != nullptr) cudaFree(data_);
}

namespace {

// Why the filters cannot run here, or empty.
std::string device_problem() {
  int devices = 0;
  if (const cudaError_t status = cudaGetDeviceCount(&devices); status != cudaSuccess) {
    cudaGetLastError();  // clear the sticky-free error so later calls are not confused
    return std::string(cudaGetErrorName(status)) + " (" + cudaGetErrorString(status) + ")";
  }
  if (devices == 0) return "no CUDA device is present";
  if (const cudaError_t status = probe_filter_kernels(); status != cudaSuccess) {
    cudaGetLastError();
    return std::string("this build's kernels cannot run on device 0: ") + cudaGetErrorName(status) +
           " (" + cudaGetErrorString(status) + ")";
  }
  return {};
}

}  // namespace

CudaVolumeFilter::CudaVolumeFilter(const VolumeFilterConfig& config, CudaFilterTuning tuning)
    : config_((config.validate(), config)),
      tuning_(tuning),
      taps_(make_gaussian_taps(config.gaussian_sigma)) {
  if (const std::string problem = device_problem(); !problem.empty()) {
    throw BackendUnavailable("backend cuda: " + problem);
  }
  check_cuda(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "cudaStreamCreate");
}

CudaVolumeFilter::~CudaVolumeFilter() {
  if (stream_ != nullptr) cudaStreamDestroy(stream_);
}

void CudaVolumeFilter::filter_volume(const Volume& in, Volume& out) {
  if (&in == &out) throw std::invalid_argument("volume filter: input and output are one volume");
  out.reshape(in.bscans(), in.ascans(), in.depth());
  if (in.bscans() == 0) return;
  run(in, out, {0, in.bscans()});
}

BscanRange CudaVolumeFilter::filter_group(const Volume& in, Volume& out, std::uint32_t first_bscan,
                                          std::uint32_t count) {
  const BscanRange outputs = check_group_request(in, out, first_bscan, count);
  run(in, out, outputs);
  return outputs;
}

void CudaVolumeFilter::reserve(std::size_t bytes) {
  if (in_.size() < bytes) {
    in_ = DeviceBytes();  // free before allocating the larger buffers
    median_ = DeviceBytes();
    out_ = DeviceBytes();
    in_ = DeviceBytes(bytes);
    median_ = DeviceBytes(bytes);
    out_ = DeviceBytes(bytes);
  }
}

void CudaVolumeFilter::run(const Volume& in, Volume& out, BscanRange outputs) {
  const std::size_t bscan_bytes = in.bscan_pixels();
  if (bscan_bytes == 0) return;
  reserve(in.pixels().size());
  const BscanRange inputs = inputs_needed_for(outputs, in.bscans());
  check_cuda(cudaMemcpyAsync(in_.get() + inputs.first * bscan_bytes,
                             in.pixels().data() + inputs.first * bscan_bytes,
                             inputs.count * bscan_bytes, cudaMemcpyHostToDevice, stream_),
             "cudaMemcpyAsync of the input B-scans");
  enqueue_volume_filter(in_.get(), median_.get(), out_.get(),
                        {in.bscans(), in.ascans(), in.depth()}, outputs, config_, taps_, tuning_,
                        stream_);
  check_cuda(
      cudaMemcpyAsync(out.bscan(outputs.first).data(), out_.get() + outputs.first * bscan_bytes,
                      outputs.count * bscan_bytes, cudaMemcpyDeviceToHost, stream_),
      "cudaMemcpyAsync of the filtered B-scans");
  check_cuda(cudaStreamSynchronize(stream_), "the volume filter kernels");
}

}  // namespace ioct::gpu::filters
