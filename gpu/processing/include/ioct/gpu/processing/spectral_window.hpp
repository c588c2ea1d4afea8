// The window applied to each background-free spectrum before the FFT: it trades a little axial
// resolution for much lower side lobes, so a bright layer does not smear over the whole A-scan.
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

namespace ioct::gpu {

enum class WindowKind {
  hann,         // 0.5 (1 - cos(2 pi n / (N - 1))), symmetric
  rectangular,  // all ones: no windowing
};

std::string_view to_string(WindowKind kind) noexcept;
// Throws ConfigError("window", ...) naming the accepted values.
WindowKind parse_window_kind(std::string_view text);

struct WindowConfig {
  WindowKind kind = WindowKind::hann;
  void validate() const;
};

// The window's N coefficients. N >= 2.
std::vector<float> make_window(WindowKind kind, std::uint32_t samples);

}  // namespace ioct::gpu
