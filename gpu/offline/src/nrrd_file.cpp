#include "ioct/gpu/offline/nrrd_file.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "ioct/common/atomic_file.hpp"
#include "ioct/gpu/offline/input_file_error.hpp"

namespace ioct::gpu::offline {
namespace {

std::string spacing_text(double spacing) {
  if (std::isnan(spacing)) return "nan";
  if (!std::isfinite(spacing) || spacing <= 0) {
    throw std::invalid_argument("NRRD spacing " + std::to_string(spacing) +
                                " is not a positive finite number (or nan for unknown)");
  }
  char text[32];
  const auto result = std::to_chars(text, text + sizeof text, spacing);
  return std::string(text, result.ptr);
}

void require_single_line(const std::string& text, const char* what) {
  if (text.find_first_of("\r\n") != std::string::npos) {
    throw std::invalid_argument(std::string("NRRD ") + what + " '" + text +
                                "' spans more than one line");
  }
}

}  // namespace

void write_nrrd(std::FILE* stream, const Volume& volume, const NrrdMetadata& metadata) {
  std::ostringstream header;
  header << "NRRD0004\n"
         << "# ioct volume: u8 [bscan][ascan][depth], depth fastest\n"
         << "type: uint8\n"
         << "dimension: 3\n"
         << "sizes: " << volume.depth() << " " << volume.ascans() << " " << volume.bscans() << "\n"
         << "spacings: " << spacing_text(metadata.spacings[0]) << " "
         << spacing_text(metadata.spacings[1]) << " " << spacing_text(metadata.spacings[2]) << "\n";
  if (!metadata.unit.empty()) {
    require_single_line(metadata.unit, "unit");
    if (metadata.unit.find('"') != std::string::npos) {
      throw std::invalid_argument("NRRD unit '" + metadata.unit + "' contains a quote");
    }
    header << "units: \"" << metadata.unit << "\" \"" << metadata.unit << "\" \"" << metadata.unit
           << "\"\n";
  }
  header << "kinds: domain domain domain\n"
         << "labels: \"depth\" \"ascan\" \"bscan\"\n";
  if (!metadata.content.empty()) {
    require_single_line(metadata.content, "content");
    header << "content: " << metadata.content << "\n";
  }
  header << "encoding: raw\n";
  for (const auto& [key, value] : metadata.key_values) {
    require_single_line(key, "key");
    require_single_line(value, "value");
    if (key.empty() || key.find(":=") != std::string::npos) {
      throw std::invalid_argument("NRRD key '" + key + "' is empty or contains ':='");
    }
    header << key << ":=" << value << "\n";
  }
  header << "\n";
  const std::string text = header.str();
  const auto pixels = volume.pixels();
  if (std::fwrite(text.data(), 1, text.size(), stream) != text.size() ||
      (!pixels.empty() && std::fwrite(pixels.data(), 1, pixels.size(), stream) != pixels.size())) {
    throw std::runtime_error(std::string("writing the NRRD volume failed: ") +
                             std::strerror(errno));
  }
}

void write_nrrd_file(const std::filesystem::path& path, const Volume& volume,
                     const NrrdMetadata& metadata) {
  AtomicFile file(path);
  write_nrrd(file.stream(), volume, metadata);
  file.commit();
}

namespace {

constexpr std::size_t kMaxHeaderBytes = 1 << 16;
// The largest volume read: 4 GiB of voxels (docs/recording-format.md, "Limits").
constexpr std::uint64_t kMaxVoxels = std::uint64_t{1} << 32;

// Whitespace-separated words of a field's value, quotes kept.
std::vector<std::string> words_of(const std::string& value) {
  std::vector<std::string> words;
  std::istringstream in(value);
  for (std::string word; in >> word;) words.push_back(word);
  return words;
}

std::string trimmed(std::string text) {
  const auto first = text.find_first_not_of(" \t");
  const auto last = text.find_last_not_of(" \t\r");
  return first == std::string::npos ? std::string() : text.substr(first, last - first + 1);
}

}  // namespace

NrrdVolume read_nrrd_file(const std::filesystem::path& path) {
  const std::uint64_t file_bytes = checked_input_size(path);  // before a FIFO could block
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputFileError(path, std::string("cannot open: ") + std::strerror(errno));
  const auto fail = [&](const std::string& problem) -> InputFileError {
    return InputFileError(path, problem);
  };

  std::string line;
  if (!std::getline(in, line) || line.size() != 8 || line.compare(0, 7, "NRRD000") != 0 ||
      line[7] < '1' || line[7] > '5') {
    throw fail("not a NRRD file (the first line must be NRRD0001 to NRRD0005)");
  }
  std::map<std::string, std::string> fields;
  NrrdMetadata metadata;
  std::size_t header_bytes = line.size() + 1;
  int line_number = 1;
  while (true) {
    if (!std::getline(in, line))
      throw fail("the header never ends (no blank line before the data)");
    ++line_number;
    header_bytes += line.size() + 1;
    if (header_bytes > kMaxHeaderBytes)
      throw fail("header longer than 64 KiB: not a volume we wrote");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) break;
    if (line[0] == '#') continue;
    const std::string where = "line " + std::to_string(line_number) + ": ";
    if (const auto kv = line.find(":="); kv != std::string::npos) {
      metadata.key_values.emplace_back(line.substr(0, kv), line.substr(kv + 2));
      continue;
    }
    const auto colon = line.find(": ");
    if (colon == std::string::npos || colon == 0) {
      throw fail(where + "'" + quote_input(line) +
                 "' is neither a field ('name: value') nor a key ('key:=value')");
    }
    const std::string name = line.substr(0, colon);
    if (!fields.emplace(name, trimmed(line.substr(colon + 2))).second) {
      throw fail(where + "field '" + quote_input(name) + "' appears twice");
    }
  }

  const auto field = [&](const std::string& name) -> const std::string& {
    const auto it = fields.find(name);
    if (it == fields.end()) throw fail("required field '" + name + "' is missing");
    return it->second;
  };
  const std::string& type = field("type");
  if (type != "uint8" && type != "uchar" && type != "unsigned char" && type != "uint8_t") {
    throw fail("type '" + quote_input(type) + "' is not supported: ioct volumes are uint8");
  }
  if (field("dimension") != "3") {
    throw fail("dimension '" + quote_input(field("dimension")) +
               "' is not supported: ioct volumes have 3");
  }
  const std::string& encoding = field("encoding");
  if (encoding != "raw") {
    throw fail("encoding '" + quote_input(encoding) + "' is not supported: only raw");
  }
  for (const char* detached : {"data file", "datafile"}) {
    if (fields.contains(detached)) throw fail("detached data ('data file') is not supported");
  }
  for (const char* skip : {"byte skip", "byteskip", "line skip", "lineskip"}) {
    if (fields.contains(skip) && fields.at(skip) != "0") {
      throw fail(std::string("field '") + skip + "' = " + quote_input(fields.at(skip)) +
                 " is not supported");
    }
  }
  std::uint64_t sizes[3] = {};
  {
    const auto words = words_of(field("sizes"));
    if (words.size() != 3)
      throw fail("sizes '" + quote_input(field("sizes")) + "' must be three numbers");
    for (int i = 0; i < 3; ++i) {
      const auto& w = words[i];
      const auto result = std::from_chars(w.data(), w.data() + w.size(), sizes[i]);
      if (result.ec != std::errc() || result.ptr != w.data() + w.size() || sizes[i] == 0 ||
          sizes[i] > 65536) {
        throw fail("sizes: '" + quote_input(w) + "' is not a whole number in [1, 65536]");
      }
    }
  }
  if (fields.contains("spacings")) {
    const auto words = words_of(fields.at("spacings"));
    if (words.size() != 3)
      throw fail("spacings '" + quote_input(fields.at("spacings")) + "' must be three numbers");
    for (int i = 0; i < 3; ++i) {
      const auto& w = words[i];
      if (w == "nan" || w == "NaN" || w == "NAN") {
        metadata.spacings[i] = std::nan("");
        continue;
      }
      double value = 0;
      const auto result = std::from_chars(w.data(), w.data() + w.size(), value);
      if (result.ec != std::errc() || result.ptr != w.data() + w.size() || !std::isfinite(value) ||
          value <= 0) {
        throw fail("spacings: '" + quote_input(w) + "' is not a positive number (or nan)");
      }
      metadata.spacings[i] = value;
    }
  }
  if (fields.contains("units")) {
    const auto words = words_of(fields.at("units"));
    if (words.size() != 3)
      throw fail("units '" + quote_input(fields.at("units")) + "' must be three words");
    auto unquote = [](std::string w) {
      return w.size() >= 2 && w.front() == '"' && w.back() == '"' ? w.substr(1, w.size() - 2) : w;
    };
    metadata.unit = unquote(words[0]);
    if (unquote(words[1]) != metadata.unit || unquote(words[2]) != metadata.unit) {
      throw fail("units '" + quote_input(fields.at("units")) +
                 "' differ between axes: not supported");
    }
  }
  if (fields.contains("content")) metadata.content = fields.at("content");

  // Each size is at most 65536, so the product fits; checked against the file before any byte
  // is allocated for it.
  const std::uint64_t voxels = sizes[0] * sizes[1] * sizes[2];
  if (voxels > kMaxVoxels) {
    throw fail("sizes " + quote_input(field("sizes")) + ": " + std::to_string(voxels) +
               " voxels, more than the " + std::to_string(kMaxVoxels) + " a volume may have");
  }
  if (file_bytes < header_bytes || file_bytes - header_bytes < voxels) {
    throw fail(
        "truncated: " + std::to_string(file_bytes > header_bytes ? file_bytes - header_bytes : 0) +
        " of the " + std::to_string(voxels) + " data bytes that sizes " +
        quote_input(field("sizes")) + " need");
  }
  NrrdVolume result;
  result.volume.reshape(static_cast<std::uint32_t>(sizes[2]), static_cast<std::uint32_t>(sizes[1]),
                        static_cast<std::uint32_t>(sizes[0]));
  result.metadata = std::move(metadata);
  std::uint64_t got = 0;
  for (std::uint32_t b = 0; b < result.volume.bscans(); ++b) {
    auto pixels = result.volume.bscan(b);
    in.read(reinterpret_cast<char*>(pixels.data()), static_cast<std::streamsize>(pixels.size()));
    got += static_cast<std::uint64_t>(in.gcount());
    if (!in) break;
  }
  if (got < voxels) {
    throw fail("truncated: " + std::to_string(got) + " of the " + std::to_string(voxels) +
               " data bytes that sizes " + quote_input(field("sizes")) + " need");
  }
  if (in.peek() != std::char_traits<char>::eof()) {
    in.seekg(0, std::ios::end);
    const auto end = static_cast<std::uint64_t>(in.tellg());
    throw fail(std::to_string(end - header_bytes - voxels) + " bytes after the " +
               std::to_string(voxels) + " data bytes that sizes " + quote_input(field("sizes")) +
               " need");
  }
  return result;
}

}  // namespace ioct::gpu::offline
