#include "ioct/gpu/filters/cuda_volume_filter.hpp"

#include <stdexcept>
#include <string>
#include <utility>

#include "filter_kernels_probe.hpp"

namespace ioct::gpu::filters {

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
  IOCT_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking));
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

BscanRange CudaVolumeFilter::filter_group(VolumeRef in, MutableVolumeRef out, BscanRange changed) {
  if (!in.is_device() && !out.is_device()) return VolumeFilter::filter_group(in, out, changed);
  if (!in.is_device() || !out.is_device()) {
    throw std::invalid_argument("volume filter (cuda): a host and a device volume together");
  }
  const VolumeDims& dims = in.dims();
  if (out.dims() != dims) {
    throw std::invalid_argument(
        "volume filter (cuda): the device output does not have the input's "
        "dimensions");
  }
  if (in.device() == out.device()) {
    throw std::invalid_argument("volume filter: input and output are one volume");
  }
  const BscanRange outputs = outputs_affected_by(changed, dims.bscans);
  if (median_.size() < dims.bytes()) median_ = cuda::DeviceArray<std::uint8_t>(dims.bytes());
  enqueue_volume_filter(in.device(), median_.data(), out.device(), dims, outputs, config_, taps_,
                        tuning_, in.stream());
  return outputs;
}

void CudaVolumeFilter::reserve(std::size_t bytes) {
  if (in_.size() < bytes) {
    in_ = {};  // free before allocating the larger buffers
    median_ = {};
    out_ = {};
    in_ = cuda::DeviceArray<std::uint8_t>(bytes);
    median_ = cuda::DeviceArray<std::uint8_t>(bytes);
    out_ = cuda::DeviceArray<std::uint8_t>(bytes);
  }
}

void CudaVolumeFilter::run(const Volume& in, Volume& out, BscanRange outputs) {
  const std::size_t bscan_bytes = in.bscan_pixels();
  if (bscan_bytes == 0) return;
  reserve(in.pixels().size());
  const BscanRange inputs = inputs_needed_for(outputs, in.bscans());
  cuda::copy_async(in_.data() + inputs.first * bscan_bytes,
                   in.pixels().data() + inputs.first * bscan_bytes, inputs.count * bscan_bytes,
                   cudaMemcpyHostToDevice, stream_, cuda::Payload::volume,
                   "copy of the input B-scans to the device");
  enqueue_volume_filter(in_.data(), median_.data(), out_.data(),
                        {in.bscans(), in.ascans(), in.depth()}, outputs, config_, taps_, tuning_,
                        stream_);
  cuda::copy_async(out.bscan(outputs.first).data(), out_.data() + outputs.first * bscan_bytes,
                   outputs.count * bscan_bytes, cudaMemcpyDeviceToHost, stream_,
                   cuda::Payload::volume, "copy of the filtered B-scans to the host");
  IOCT_CUDA_CHECK(cudaStreamSynchronize(stream_));  // also reports the kernels' errors
}

}  // namespace ioct::gpu::filters
