#include "preset_store.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "ioct/common/atomic_file.hpp"

namespace ioct::view {
namespace {

std::optional<nlohmann::json> read_json_file(const std::filesystem::path& file) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) return std::nullopt;
  const auto size = std::filesystem::file_size(file, ec);
  if (ec || size > PresetStore::kMaxFileBytes) return std::nullopt;
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  nlohmann::json j = nlohmann::json::parse(text.str(), nullptr, false);
  if (j.is_discarded() || !j.is_object()) return std::nullopt;
  return j;
}

}  // namespace

PresetStore::PresetStore(std::filesystem::path state_dir) : dir_(std::move(state_dir)) {
  std::error_code ec;
  std::filesystem::create_directories(dir_ / "presets", ec);
}

bool PresetStore::valid_name(std::string_view name) noexcept {
  if (name.empty() || name.size() > 64) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-';
  });
}

std::vector<std::string> PresetStore::names() const {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir_ / "presets", ec)) {
    if (entry.path().extension() != ".json") continue;
    const std::string stem = entry.path().stem().string();
    if (valid_name(stem)) out.push_back(stem);
  }
  std::sort(out.begin(), out.end());
  return out;
}

void PresetStore::save(const std::string& name, const nlohmann::json& params) {
  write_text_file_atomically(dir_ / "presets" / (name + ".json"), params.dump(2) + "\n");
}

std::optional<nlohmann::json> PresetStore::load(const std::string& name) const {
  if (!valid_name(name)) return std::nullopt;
  return read_json_file(dir_ / "presets" / (name + ".json"));
}

bool PresetStore::remove(const std::string& name) {
  std::error_code ec;
  return valid_name(name) && std::filesystem::remove(dir_ / "presets" / (name + ".json"), ec);
}

void PresetStore::save_last(const nlohmann::json& params) {
  write_text_file_atomically(dir_ / "params.json", params.dump(2) + "\n");
}

std::optional<nlohmann::json> PresetStore::load_last() const {
  return read_json_file(dir_ / "params.json");
}

}  // namespace ioct::view
