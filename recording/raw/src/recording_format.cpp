#include "ioct/recording/recording_format.hpp"

#include <time.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <string>

#include "ioct/common/strict_json.hpp"

namespace ioct::recording {
namespace {

using nlohmann::json;

// A value of the file as a message may show it (escaped, shortened).
std::string shown(const json& value) {
  return shown_json(value);
}

static_assert(std::endian::native == std::endian::little,
              "the recording format is little-endian and is read and written in place");

[[noreturn]] void fail(const std::string& source, const std::string& what) {
  throw RecordingError(source + ": " + what);
}

const json& member(const json& object, const char* key, const std::string& path,
                   const std::string& source) {
  if (!object.is_object()) fail(source, "'" + path + "' must be a JSON object");
  const auto it = object.find(key);
  if (it == object.end()) {
    fail(source, "missing key '" + (path.empty() ? std::string(key) : path + "." + key) + "'");
  }
  return *it;
}

std::string join(const std::string& path, const char* key) {
  return path.empty() ? std::string(key) : path + "." + key;
}

std::uint64_t unsigned_in(const json& object, const char* key, const std::string& path,
                          const std::string& source, std::uint64_t lo, std::uint64_t hi) {
  const json& value = member(object, key, path, source);
  if (!value.is_number_unsigned() &&
      !(value.is_number_integer() && value.get<std::int64_t>() >= 0)) {
    fail(source, join(path, key) + " = " + shown(value) + ": must be an integer in [" +
                     std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  const auto v = value.get<std::uint64_t>();
  if (v < lo || v > hi) {
    fail(source, join(path, key) + " = " + shown(value) + ": must be an integer in [" +
                     std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  return v;
}

double real_in(const json& object, const char* key, const std::string& path,
               const std::string& source, double lo, double hi) {
  const json& value = member(object, key, path, source);
  if (!value.is_number() || !std::isfinite(value.get<double>()) || value.get<double>() < lo ||
      value.get<double>() > hi) {
    fail(source, join(path, key) + " = " + shown(value) + ": must be a number in [" +
                     json(lo).dump() + ", " + json(hi).dump() + "]");
  }
  return value.get<double>();
}

std::string text(const json& object, const char* key, const std::string& path,
                 const std::string& source) {
  const json& value = member(object, key, path, source);
  if (!value.is_string())
    fail(source, join(path, key) + " = " + shown(value) + ": must be a string");
  return value.get<std::string>();
}

}  // namespace

void GroupTruth::resize(std::uint32_t ascans, std::uint32_t bscan_count, std::uint32_t tool_count) {
  ascans_per_bscan = ascans;
  bscans = bscan_count;
  tools = tool_count;
  const std::size_t n = std::size_t{ascans} * bscan_count;
  for (std::vector<float>* v : {&ilm_px, &rpe_px, &tool_px, &beam_x, &beam_y}) v->assign(n, 0.0f);
  tool_states.assign(std::size_t{bscan_count} * tool_count, ToolState{});
}

std::uint64_t GroupTruth::record_bytes(std::uint32_t ascans, std::uint32_t bscan_count,
                                       std::uint32_t tool_count) noexcept {
  const std::uint64_t n = std::uint64_t{ascans} * bscan_count;
  return kTruthHeaderBytes + 5 * 4 * n +
         std::uint64_t{bscan_count} * tool_count * kToolStateFloats * 4;
}

bool same_bytes(const GroupTruth& a, const GroupTruth& b) noexcept {
  const auto same = [](const auto& x, const auto& y) {
    return x.size() == y.size() &&
           (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0);
  };
  return a.group_index == b.group_index && a.first_sweep_counter == b.first_sweep_counter &&
         a.ascans_per_bscan == b.ascans_per_bscan && a.bscans == b.bscans && a.tools == b.tools &&
         same(a.ilm_px, b.ilm_px) && same(a.rpe_px, b.rpe_px) && same(a.tool_px, b.tool_px) &&
         same(a.beam_x, b.beam_x) && same(a.beam_y, b.beam_y) && same(a.tool_states, b.tool_states);
}

json to_json(const RecordingMetadata& m) {
  const RecordingGeometry& g = m.geometry;
  json out;
  out["format"] = kFormatName;
  out["version"] = kFormatVersion;
  out["producer"] = m.producer;
  out["created_utc"] = m.created_utc;
  out["geometry"] = {{"samples_per_ascan", g.samples_per_ascan},
                     {"ascans_per_bscan", g.ascans_per_bscan},
                     {"flyback_sweeps", g.flyback_sweeps},
                     {"bscans_per_group", g.bscans_per_group},
                     {"bscans_per_volume", g.bscans_per_volume},
                     {"ascan_rate_hz", g.ascan_rate_hz},
                     {"sample_bits", g.sample_bits},
                     {"clock_source", g.clock_source}};
  out["scan"] = {{"pattern", m.scan.pattern},   {"bidirectional", m.scan.bidirectional},
                 {"center_x", m.scan.center_x}, {"center_y", m.scan.center_y},
                 {"extent_x", m.scan.extent_x}, {"extent_y", m.scan.extent_y}};
  out["sample_format"] = {{"dtype", "<u2"},
                          {"layout", {"group", "bscan", "ascan", "sample"}},
                          {"right_aligned_bits", g.sample_bits}};
  out["calibration"] = {{"resampling_coefficients", m.resampling_coefficients},
                        {"dispersion_c2", m.dispersion_c2},
                        {"dispersion_c3", m.dispersion_c3}};
  out["acquisition"] = m.acquisition;
  return out;
}

RecordingMetadata metadata_from_json(const json& in, const std::string& source) {
  if (!in.is_object()) fail(source, "the metadata must be a JSON object");
  const std::string format = text(in, "format", "", source);
  if (format != kFormatName) {
    fail(source, "format = " + shown(format) + ": not an ioct raw recording (expected \"" +
                     kFormatName + "\")");
  }
  const std::uint64_t version = unsigned_in(in, "version", "", source, 0, 1u << 30);
  if (version != kFormatVersion) {
    fail(source, "version = " + std::to_string(version) + ": this build reads version " +
                     std::to_string(kFormatVersion));
  }
  RecordingMetadata m;
  m.producer = text(in, "producer", "", source);
  m.created_utc = text(in, "created_utc", "", source);
  const json& g = member(in, "geometry", "", source);
  const std::string path = "geometry";
  RecordingGeometry& geometry = m.geometry;
  geometry.samples_per_ascan =
      static_cast<std::uint32_t>(unsigned_in(g, "samples_per_ascan", path, source, 16, 65536));
  if (geometry.samples_per_ascan % 2 != 0) {
    fail(source, "geometry.samples_per_ascan = " + std::to_string(geometry.samples_per_ascan) +
                     ": must be even");
  }
  geometry.ascans_per_bscan =
      static_cast<std::uint32_t>(unsigned_in(g, "ascans_per_bscan", path, source, 1, 65536));
  geometry.flyback_sweeps =
      static_cast<std::uint32_t>(unsigned_in(g, "flyback_sweeps", path, source, 0, 65536));
  geometry.bscans_per_group =
      static_cast<std::uint32_t>(unsigned_in(g, "bscans_per_group", path, source, 1, 4096));
  geometry.bscans_per_volume =
      static_cast<std::uint32_t>(unsigned_in(g, "bscans_per_volume", path, source, 1, 65536));
  geometry.ascan_rate_hz = real_in(g, "ascan_rate_hz", path, source, 1.0, 1e8);
  geometry.sample_bits =
      static_cast<std::uint32_t>(unsigned_in(g, "sample_bits", path, source, 1, 16));
  geometry.clock_source = text(g, "clock_source", path, source);
  if (geometry.clock_source != "external_k_clock" && geometry.clock_source != "internal") {
    fail(source, "geometry.clock_source = " + shown(geometry.clock_source) +
                     ": must be \"external_k_clock\" or \"internal\"");
  }
  if (geometry.samples_per_group() > (std::uint64_t{1} << 32)) {
    fail(source, "geometry: " + std::to_string(geometry.samples_per_group()) +
                     " samples per group; at most 2^32 are supported");
  }
  const json& scan = member(in, "scan", "", source);
  m.scan.pattern = text(scan, "pattern", "scan", source);
  if (m.scan.pattern != "raster") {
    fail(source, "scan.pattern = " + shown(m.scan.pattern) + ": this build knows \"raster\"");
  }
  const json& bidirectional = member(scan, "bidirectional", "scan", source);
  if (!bidirectional.is_boolean()) {
    fail(source, "scan.bidirectional = " + shown(bidirectional) + ": must be true or false");
  }
  m.scan.bidirectional = bidirectional.get<bool>();
  m.scan.center_x = real_in(scan, "center_x", "scan", source, -1.0, 1.0);
  m.scan.center_y = real_in(scan, "center_y", "scan", source, -1.0, 1.0);
  m.scan.extent_x = real_in(scan, "extent_x", "scan", source, 0.0, 1.0);
  m.scan.extent_y = real_in(scan, "extent_y", "scan", source, 0.0, 1.0);
  const json& calibration = member(in, "calibration", "", source);
  const json& coefficients = member(calibration, "resampling_coefficients", "calibration", source);
  if (!coefficients.is_array() || coefficients.empty() || coefficients.size() > 8) {
    fail(source, "calibration.resampling_coefficients = " + shown(coefficients) +
                     ": must be an array of 1 to 8 numbers");
  }
  m.resampling_coefficients.clear();
  for (std::size_t i = 0; i < coefficients.size(); ++i) {
    if (!coefficients[i].is_number() || !std::isfinite(coefficients[i].get<double>())) {
      fail(source, "calibration.resampling_coefficients[" + std::to_string(i) +
                       "] = " + shown(coefficients[i]) + ": must be a finite number");
    }
    m.resampling_coefficients.push_back(coefficients[i].get<double>());
  }
  m.dispersion_c2 = real_in(calibration, "dispersion_c2", "calibration", source, -1e4, 1e4);
  m.dispersion_c3 = real_in(calibration, "dispersion_c3", "calibration", source, -1e4, 1e4);
  const auto acquisition = in.find("acquisition");
  if (acquisition != in.end()) m.acquisition = *acquisition;
  const auto truth = in.find("truth");
  if (truth != in.end() && !truth->is_null()) {
    m.has_truth = true;
    m.truth_tools =
        static_cast<std::uint32_t>(unsigned_in(*truth, "tools", "truth", source, 0, 64));
  }
  return m;
}

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  ::gmtime_r(&now, &utc);
  char text_buffer[32];
  std::strftime(text_buffer, sizeof(text_buffer), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text_buffer;
}

}  // namespace ioct::recording
