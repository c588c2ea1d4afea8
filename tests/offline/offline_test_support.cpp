#include "offline_test_support.hpp"

#include <cstdlib>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace ioct::gpu::offline::testing {

namespace fs = std::filesystem;

ScratchDir::ScratchDir() {
  std::string pattern = (fs::temp_directory_path() / "ioct-offline-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  path_ = pattern;
}

ScratchDir::~ScratchDir() {
  std::error_code ignored;
  fs::remove_all(path_, ignored);
}

std::vector<std::string> ScratchDir::entries() const {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(path_)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

std::vector<std::uint16_t> make_spectra(const SpectraSpec& spec) {
  std::vector<std::uint16_t> values(std::size_t{spec.bscans} * spec.ascans * spec.samples);
  std::mt19937 rng(spec.seed);
  std::normal_distribution<double> noise(0.0, 2.0);
  std::uniform_real_distribution<double> phase(0.0, 2 * std::numbers::pi);
  const double n = spec.samples;
  std::size_t k = 0;
  for (std::uint32_t b = 0; b < spec.bscans; ++b) {
    for (std::uint32_t a = 0; a < spec.ascans; ++a) {
      const double f = spec.depth(b, a);
      const double phi = phase(rng);
      for (std::uint32_t i = 0; i < spec.samples; ++i) {
        const double u = spec.position(i);
        const double envelope = std::exp(-std::pow((u - n / 2) / (0.35 * n), 2));
        const double value =
            2048 + 500 * envelope +
            spec.amplitude * envelope * std::cos(2 * std::numbers::pi * f * u / n + phi) +
            noise(rng);
        values[k++] = static_cast<std::uint16_t>(std::clamp(std::lround(value), 0L, 4095L));
      }
    }
  }
  return values;
}

void write_u16_file(const fs::path& path, const std::vector<std::uint16_t>& values,
                    bool little_endian, std::size_t header_bytes) {
  std::vector<std::uint8_t> bytes(header_bytes, 0);
  bytes.reserve(header_bytes + 2 * values.size());
  for (std::uint16_t v : values) {
    const auto lo = static_cast<std::uint8_t>(v & 0xFF);
    const auto hi = static_cast<std::uint8_t>(v >> 8);
    bytes.push_back(little_endian ? lo : hi);
    bytes.push_back(little_endian ? hi : lo);
  }
  write_bytes(path, bytes);
}

double inverse_calibration_position(const std::vector<double>& c, std::uint32_t samples,
                                    std::uint32_t i) {
  const double n1 = samples - 1.0;
  const auto x = [&](double t) {
    double sum = 0, power = 1;
    for (double ci : c) {
      sum += ci * power;
      power *= t;
    }
    return n1 * sum;
  };
  double lo = 0, hi = 1;  // x increases over [0, 1]: bisect for x(t) = i
  for (int step = 0; step < 60; ++step) {
    const double mid = (lo + hi) / 2;
    (x(mid) < i ? lo : hi) = mid;
  }
  return n1 * (lo + hi) / 2;
}

float vol_intensity(std::uint32_t b, std::uint32_t y, std::uint32_t x) {
  if (b == 1 && y == 0 && x == 0) return 3.4028234663852886e38f;  // no data
  return float((b * 31 + y * 7 + x * 3) % 17) / 16.0f;            // 0 .. 1
}

float vol_line(std::uint32_t b, std::uint32_t l, std::uint32_t x) {
  if (l == 0 && x == 0) return 3.4028234663852886e38f;  // no line at the first A-scan
  return 1.25f + float(l) + 0.5f * float(x % 3) + float(b);
}

namespace {

void put_u32(std::vector<std::uint8_t>& bytes, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) bytes[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put_f32(std::vector<std::uint8_t>& bytes, std::size_t at, float v) {
  std::uint32_t bits;
  std::memcpy(&bits, &v, 4);
  put_u32(bytes, at, bits);
}
void put_f64(std::vector<std::uint8_t>& bytes, std::size_t at, double v) {
  std::uint64_t bits;
  std::memcpy(&bits, &v, 8);
  put_u32(bytes, at, static_cast<std::uint32_t>(bits));
  put_u32(bytes, at + 4, static_cast<std::uint32_t>(bits >> 32));
}
void put_text(std::vector<std::uint8_t>& bytes, std::size_t at, const char* text) {
  std::memcpy(&bytes[at], text, std::strlen(text));
}

}  // namespace

std::vector<std::uint8_t> make_vol_bytes(const VolSpec& s) {
  const std::size_t slo = std::size_t{s.slo_width} * s.slo_height;
  const std::size_t image = std::size_t{s.ascans} * s.depth * 4;
  std::vector<std::uint8_t> bytes(2048 + slo + s.bscans * (s.bscan_header_bytes + image), 0);
  put_text(bytes, 0, "HSF-OCT-103");
  put_u32(bytes, 12, s.ascans);
  put_u32(bytes, 16, s.bscans);
  put_u32(bytes, 20, s.depth);
  put_f64(bytes, 24, s.scale_x);
  put_f64(bytes, 32, s.distance);
  put_f64(bytes, 40, s.scale_y);
  put_u32(bytes, 48, s.slo_width);
  put_u32(bytes, 52, s.slo_height);
  put_f64(bytes, 56, 0.0142);
  put_f64(bytes, 64, 0.0142);
  put_text(bytes, 84, "OS");
  put_u32(bytes, 96, static_cast<std::uint32_t>(s.scan_pattern));
  put_u32(bytes, 100, s.bscan_header_bytes);
  put_text(bytes, 140, "patient-id-not-read");
  for (std::size_t i = 0; i < slo; ++i) bytes[2048 + i] = static_cast<std::uint8_t>(i * 11);
  for (std::uint32_t b = 0; b < s.bscans; ++b) {
    const std::size_t at = 2048 + slo + b * (s.bscan_header_bytes + image);
    put_text(bytes, at, "HSF-BS-103");
    put_u32(bytes, at + 12, s.bscan_header_bytes);
    put_f64(bytes, at + 16, -1.5 + b);
    put_f64(bytes, at + 24, 0.25);
    put_f64(bytes, at + 32, 1.5 + b);
    put_f64(bytes, at + 40, 0.25);
    put_u32(bytes, at + 48, s.lines);
    put_u32(bytes, at + 52, 256);
    put_f32(bytes, at + 56, 30.5f);
    put_u32(bytes, at + 60, static_cast<std::uint32_t>(-3));
    for (std::uint32_t l = 0; l < s.lines; ++l) {
      for (std::uint32_t x = 0; x < s.ascans; ++x) {
        put_f32(bytes, at + 256 + (std::size_t{l} * s.ascans + x) * 4, vol_line(b, l, x));
      }
    }
    for (std::uint32_t y = 0; y < s.depth; ++y) {
      for (std::uint32_t x = 0; x < s.ascans; ++x) {
        put_f32(bytes, at + s.bscan_header_bytes + (std::size_t{y} * s.ascans + x) * 4,
                vol_intensity(b, y, x));
      }
    }
  }
  return bytes;
}

void write_bytes(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::vector<std::uint8_t> read_bytes(const fs::path& path) {
  const std::string text = read_text(path);
  return {text.begin(), text.end()};
}

ToolResult run_tool(const std::string& executable, const std::vector<std::string>& arguments,
                    const fs::path& dir) {
  std::vector<std::string> args = arguments;
  args.insert(args.begin(), executable);
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const fs::path out = dir / ".tool-stdout", err = dir / ".tool-stderr";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw std::runtime_error("cannot start " + executable + ": " + std::strerror(rc));
  ToolResult result;
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      result.err = "timed out";
      return result;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  result.out = read_text(out);
  result.err = read_text(err);
  fs::remove(out);
  fs::remove(err);
  return result;
}

fs::path spectralis_vol_file() {
  const char* dir = std::getenv("IOCT_TEST_DATA_DIR");
  const fs::path base = dir != nullptr && *dir != '\0' ? fs::path(dir) : fs::path(IOCT_TEST_DATA_DIR);
  const fs::path path = base / "spectralis_circle_valid.vol";
  return fs::exists(path) ? path : fs::path();
}

}  // namespace ioct::gpu::offline::testing
