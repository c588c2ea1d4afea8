// Named render presets and the last parameters, kept as JSON files in the view's state folder so
// they survive restarts of any process: <state>/presets/<name>.json and <state>/params.json.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace ioct::view {

class PresetStore {
 public:
  explicit PresetStore(std::filesystem::path state_dir);

  // A preset name: 1 to 64 of [A-Za-z0-9_-], so it is always a plain file name.
  static bool valid_name(std::string_view name) noexcept;

  std::vector<std::string> names() const;
  // Throws std::runtime_error naming the file when it cannot be written.
  void save(const std::string& name, const nlohmann::json& params);
  // Nullopt when there is no such file; throws std::runtime_error naming the file and what is
  // wrong when it cannot be used (unreadable, too large, not a JSON object).
  std::optional<nlohmann::json> load(const std::string& name) const;
  bool remove(const std::string& name);

  void save_last(const nlohmann::json& params);
  std::optional<nlohmann::json> load_last() const;  // as load()
  std::filesystem::path last_params_file() const { return dir_ / "params.json"; }

  static constexpr std::size_t kMaxFileBytes = 1u << 20;

 private:
  std::filesystem::path dir_;
};

}  // namespace ioct::view
