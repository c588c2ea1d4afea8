#include "preset_store.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "ioct/common/atomic_file.hpp"

namespace ioct::view {
namespace {

std::optional<nlohmann::json> read_json_file(const std::filesystem::path& file) {
  std::error_code ec;
  const auto status = std::filesystem::status(file, ec);
  if (status.type() == std::filesystem::file_type::not_found) return std::nullopt;
  const auto unusable = [&](const std::string& why) {
    return std::runtime_error(file.string() + ": " + why);
  };
  if (ec) throw unusable(ec.message());
  if (!std::filesystem::is_regular_file(status)) throw unusable("not a regular file");
  const auto size = std::filesystem::file_size(file, ec);
  if (ec) throw unusable(ec.message());
  if (size > PresetStore::kMaxFileBytes) {
    throw unusable("larger than " + std::to_string(PresetStore::kMaxFileBytes) + " bytes");
  }
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) throw unusable("cannot be read");
  nlohmann::json j = nlohmann::json::parse(text.str(), nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw unusable("not a JSON object");
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
  write_text_file_atomically(last_params_file(), params.dump(2) + "\n");
}

std::optional<nlohmann::json> PresetStore::load_last() const {
  return read_json_file(last_params_file());
}

}  // namespace ioct::view
