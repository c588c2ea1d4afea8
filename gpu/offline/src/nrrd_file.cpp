#include "ioct/gpu/offline/nrrd_file.hpp"

#include <array>
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

// The header up to its blank line: fields ("name: value"), keys ("key:=value") in the file's
// order, and its length in bytes (where the data starts).
struct NrrdHeader {
  std::map<std::string, std::string> fields;
  std::vector<std::pair<std::string, std::string>> key_values;
  std::size_t bytes = 0;
};

NrrdHeader read_header(std::istream& in, const std::filesystem::path& path) {
  std::string line;
  if (!std::getline(in, line) || line.size() != 8 || line.compare(0, 7, "NRRD000") != 0 ||
      line[7] < '1' || line[7] > '5') {
    throw InputFileError(path, "not a NRRD file (the first line must be NRRD0001 to NRRD0005)");
  }
  NrrdHeader header;
  header.bytes = line.size() + 1;
  int line_number = 1;
  while (true) {
    if (!std::getline(in, line))
      throw InputFileError(path, "the header never ends (no blank line before the data)");
    ++line_number;
    header.bytes += line.size() + 1;
    if (header.bytes > kMaxHeaderBytes)
      throw InputFileError(path, "header longer than 64 KiB: not a volume we wrote");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) break;
    if (line[0] == '#') continue;
    const std::string where = "line " + std::to_string(line_number) + ": ";
    if (const auto kv = line.find(":="); kv != std::string::npos) {
      header.key_values.emplace_back(line.substr(0, kv), line.substr(kv + 2));
      continue;
    }
    const auto colon = line.find(": ");
    if (colon == std::string::npos || colon == 0) {
      throw InputFileError(path,
                           where + "'" + quote_input(line) +
                               "' is neither a field ('name: value') nor a key ('key:=value')");
    }
    const std::string name = line.substr(0, colon);
    if (!header.fields.emplace(name, trimmed(line.substr(colon + 2))).second) {
      throw InputFileError(path, where + "field '" + quote_input(name) + "' appears twice");
    }
  }
  return header;
}

const std::string& required_field(const std::map<std::string, std::string>& fields,
                                  const std::string& name, const std::filesystem::path& path) {
  const auto it = fields.find(name);
  if (it == fields.end()) throw InputFileError(path, "required field '" + name + "' is missing");
  return it->second;
}

// Refuses what ioct volumes never are: another type or dimension, an encoding, detached data or
// skipped bytes.
void check_supported_layout(const std::map<std::string, std::string>& fields,
                            const std::filesystem::path& path) {
  const std::string& type = required_field(fields, "type", path);
  if (type != "uint8" && type != "uchar" && type != "unsigned char" && type != "uint8_t") {
    throw InputFileError(
        path, "type '" + quote_input(type) + "' is not supported: ioct volumes are uint8");
  }
  const std::string& dimension = required_field(fields, "dimension", path);
  if (dimension != "3") {
    throw InputFileError(
        path, "dimension '" + quote_input(dimension) + "' is not supported: ioct volumes have 3");
  }
  const std::string& encoding = required_field(fields, "encoding", path);
  if (encoding != "raw") {
    throw InputFileError(path,
                         "encoding '" + quote_input(encoding) + "' is not supported: only raw");
  }
  for (const char* detached : {"data file", "datafile"}) {
    if (fields.contains(detached)) {
      throw InputFileError(path, "detached data ('data file') is not supported");
    }
  }
  for (const char* skip : {"byte skip", "byteskip", "line skip", "lineskip"}) {
    if (fields.contains(skip) && fields.at(skip) != "0") {
      throw InputFileError(path, std::string("field '") + skip +
                                     "' = " + quote_input(fields.at(skip)) + " is not supported");
    }
  }
}

// The three sizes, depth fastest.
std::array<std::uint64_t, 3> parse_sizes(const std::string& text,
                                         const std::filesystem::path& path) {
  const auto words = words_of(text);
  if (words.size() != 3) {
    throw InputFileError(path, "sizes '" + quote_input(text) + "' must be three numbers");
  }
  std::array<std::uint64_t, 3> sizes = {};
  for (int i = 0; i < 3; ++i) {
    const auto& w = words[i];
    const auto result = std::from_chars(w.data(), w.data() + w.size(), sizes[i]);
    if (result.ec != std::errc() || result.ptr != w.data() + w.size() || sizes[i] == 0 ||
        sizes[i] > 65536) {
      throw InputFileError(path,
                           "sizes: '" + quote_input(w) + "' is not a whole number in [1, 65536]");
    }
  }
  return sizes;
}

std::array<double, 3> parse_spacings(const std::string& text, const std::filesystem::path& path) {
  const auto words = words_of(text);
  if (words.size() != 3) {
    throw InputFileError(path, "spacings '" + quote_input(text) + "' must be three numbers");
  }
  std::array<double, 3> spacings = {};
  for (int i = 0; i < 3; ++i) {
    const auto& w = words[i];
    if (w == "nan" || w == "NaN" || w == "NAN") {
      spacings[i] = std::nan("");
      continue;
    }
    double value = 0;
    const auto result = std::from_chars(w.data(), w.data() + w.size(), value);
    if (result.ec != std::errc() || result.ptr != w.data() + w.size() || !std::isfinite(value) ||
        value <= 0) {
      throw InputFileError(path,
                           "spacings: '" + quote_input(w) + "' is not a positive number (or nan)");
    }
    spacings[i] = value;
  }
  return spacings;
}

// The one unit of all three axes: NrrdMetadata has no room for one per axis.
std::string parse_unit(const std::string& text, const std::filesystem::path& path) {
  const auto words = words_of(text);
  if (words.size() != 3) {
    throw InputFileError(path, "units '" + quote_input(text) + "' must be three words");
  }
  auto unquote = [](std::string w) {
    return w.size() >= 2 && w.front() == '"' && w.back() == '"' ? w.substr(1, w.size() - 2) : w;
  };
  std::string unit = unquote(words[0]);
  if (unquote(words[1]) != unit || unquote(words[2]) != unit) {
    throw InputFileError(path,
                         "units '" + quote_input(text) + "' differ between axes: not supported");
  }
  return unit;
}

// Moves the header's keys into the metadata; its fields stay.
NrrdMetadata metadata_of(NrrdHeader& header, const std::filesystem::path& path) {
  NrrdMetadata metadata;
  metadata.key_values = std::move(header.key_values);
  const auto& fields = header.fields;
  if (fields.contains("spacings")) metadata.spacings = parse_spacings(fields.at("spacings"), path);
  if (fields.contains("units")) metadata.unit = parse_unit(fields.at("units"), path);
  if (fields.contains("content")) metadata.content = fields.at("content");
  return metadata;
}

// The voxels that `sizes` need, checked against the limit and the file's length before any byte
// is allocated for them.
std::uint64_t checked_voxels(const std::array<std::uint64_t, 3>& sizes,
                             const std::string& sizes_text, std::uint64_t file_bytes,
                             std::size_t header_bytes, const std::filesystem::path& path) {
  // Each size is at most 65536, so the product fits.
  const std::uint64_t voxels = sizes[0] * sizes[1] * sizes[2];
  if (voxels > kMaxVoxels) {
    throw InputFileError(path, "sizes " + quote_input(sizes_text) + ": " + std::to_string(voxels) +
                                   " voxels, more than the " + std::to_string(kMaxVoxels) +
                                   " a volume may have");
  }
  if (file_bytes < header_bytes || file_bytes - header_bytes < voxels) {
    throw InputFileError(
        path,
        "truncated: " + std::to_string(file_bytes > header_bytes ? file_bytes - header_bytes : 0) +
            " of the " + std::to_string(voxels) + " data bytes that sizes " +
            quote_input(sizes_text) + " need");
  }
  return voxels;
}

// Checks the length again as it reads: the file may have changed since it was measured.
void read_voxels(std::istream& in, Volume& volume, std::uint64_t voxels,
                 const std::string& sizes_text, std::size_t header_bytes,
                 const std::filesystem::path& path) {
  std::uint64_t got = 0;
  for (std::uint32_t b = 0; b < volume.bscans(); ++b) {
    auto pixels = volume.bscan(b);
    in.read(reinterpret_cast<char*>(pixels.data()), static_cast<std::streamsize>(pixels.size()));
    got += static_cast<std::uint64_t>(in.gcount());
    if (!in) break;
  }
  if (got < voxels) {
    throw InputFileError(path, "truncated: " + std::to_string(got) + " of the " +
                                   std::to_string(voxels) + " data bytes that sizes " +
                                   quote_input(sizes_text) + " need");
  }
  if (in.peek() != std::char_traits<char>::eof()) {
    in.seekg(0, std::ios::end);
    const auto end = static_cast<std::uint64_t>(in.tellg());
    throw InputFileError(path, std::to_string(end - header_bytes - voxels) + " bytes after the " +
                                   std::to_string(voxels) + " data bytes that sizes " +
                                   quote_input(sizes_text) + " need");
  }
}

}  // namespace

NrrdVolume read_nrrd_file(const std::filesystem::path& path) {
  const std::uint64_t file_bytes = checked_input_size(path);  // before a FIFO could block
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputFileError(path, std::string("cannot open: ") + std::strerror(errno));

  NrrdHeader header = read_header(in, path);
  check_supported_layout(header.fields, path);
  const std::string& sizes_text = required_field(header.fields, "sizes", path);
  const std::array<std::uint64_t, 3> sizes = parse_sizes(sizes_text, path);
  NrrdMetadata metadata = metadata_of(header, path);
  const std::uint64_t voxels = checked_voxels(sizes, sizes_text, file_bytes, header.bytes, path);

  NrrdVolume result;
  result.volume.reshape(static_cast<std::uint32_t>(sizes[2]), static_cast<std::uint32_t>(sizes[1]),
                        static_cast<std::uint32_t>(sizes[0]));
  result.metadata = std::move(metadata);
  read_voxels(in, result.volume, voxels, sizes_text, header.bytes, path);
  return result;
}

}  // namespace ioct::gpu::offline
