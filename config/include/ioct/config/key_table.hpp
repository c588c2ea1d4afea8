// A config struct's keys, each declared once: name, member, range, flag, one line of doc. The file
// reader, the range checks of validate(), the command line, the printed effective configuration
// and the key table in docs/ all read from the declaration.
//
//   KeyTable<RtConfig> keys;
//   keys.integer("ring.slots", [](auto& c) -> auto& { return c.ring_slots; }, 2, 4096,
//                "slots in the ring, each one group", "--slots");
//
// A member is reached by a generic lambda returning a reference, so one declaration serves a
// const config (printing, checking) and a mutable one (reading).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/config/key_spec.hpp"

// A field of a config, as a KeyTable reaches it: one generic lambda serves a const and a mutable
// config, e.g. IOCT_MEMBER(processing.window). `expr` names a member: it cannot be parenthesised.
// NOLINTBEGIN(bugprone-macro-parentheses)
#define IOCT_MEMBER(expr) \
  [](auto& c) -> auto& {  \
    return c.expr;        \
  }
// NOLINTEND(bugprone-macro-parentheses)

namespace ioct::config {

template <typename Config>
class KeyTable {
 public:
  template <typename Ref>
  KeyTable& integer(std::string key, Ref ref, std::int64_t lo, std::int64_t hi, std::string doc,
                    std::string flag = {}) {
    KeySpec spec = make(std::move(key), KeyKind::integer, std::move(doc), std::move(flag));
    spec.lo = lo;
    spec.hi = hi;
    return add(
        std::move(spec), [ref](const Config& c) { return Value(std::int64_t(ref(c))); },
        [ref](Config& c, const Value& v) {
          using T = std::remove_reference_t<decltype(ref(c))>;
          ref(c) = static_cast<T>(std::get<std::int64_t>(v));
        });
  }

  // An integer in [lo, hi] or "auto", kept in the member as -1.
  template <typename Ref>
  KeyTable& integer_or_auto(std::string key, Ref ref, std::int64_t lo, std::int64_t hi,
                            std::string doc, std::string flag = {}) {
    integer(std::move(key), ref, lo, hi, std::move(doc), std::move(flag));
    specs_.back().kind = KeyKind::integer_or_auto;
    return *this;
  }

  // A real checked by the component's own validate(), or here when given a range.
  template <typename Ref>
  KeyTable& real(std::string key, Ref ref, std::string doc, std::string flag = {}) {
    KeySpec spec = make(std::move(key), KeyKind::real, std::move(doc), std::move(flag));
    return add(
        std::move(spec), [ref](const Config& c) { return Value(double(ref(c))); },
        [ref](Config& c, const Value& v) {
          using T = std::remove_reference_t<decltype(ref(c))>;
          ref(c) = static_cast<T>(std::get<double>(v));
        });
  }
  template <typename Ref>
  KeyTable& real_in(std::string key, Ref ref, double lo, double hi, std::string doc,
                    std::string flag = {}) {
    real(std::move(key), ref, std::move(doc), std::move(flag));
    KeySpec& spec = specs_.back();
    spec.real_bounded = true;
    spec.real_lo = lo;
    spec.real_hi = hi;
    return *this;
  }

  template <typename Ref>
  KeyTable& boolean(std::string key, Ref ref, std::string doc, std::string flag = {}) {
    KeySpec spec = make(std::move(key), KeyKind::boolean, std::move(doc), std::move(flag));
    return add(
        std::move(spec), [ref](const Config& c) { return Value(bool(ref(c))); },
        [ref](Config& c, const Value& v) { ref(c) = std::get<bool>(v); });
  }

  template <typename Ref>
  KeyTable& text(std::string key, Ref ref, std::string doc, std::string flag = {}) {
    KeySpec spec = make(std::move(key), KeyKind::text, std::move(doc), std::move(flag));
    return add(
        std::move(spec), [ref](const Config& c) { return Value(std::string(ref(c))); },
        [ref](Config& c, const Value& v) { ref(c) = std::get<std::string>(v); });
  }

  template <typename Ref>
  KeyTable& text_list(std::string key, Ref ref, std::string doc, std::string flag = {}) {
    KeySpec spec = make(std::move(key), KeyKind::text_list, std::move(doc), std::move(flag));
    return add(
        std::move(spec), [ref](const Config& c) { return Value(ref(c)); },
        [ref](Config& c, const Value& v) { ref(c) = std::get<std::vector<std::string>>(v); });
  }

  // One of `allowed`, kept in a std::string member.
  template <typename Ref>
  KeyTable& choice(std::string key, Ref ref, std::vector<std::string> allowed, std::string doc,
                   std::string flag = {}) {
    return choice_of(
        std::move(key), std::move(allowed), [ref](const Config& c) { return std::string(ref(c)); },
        [ref](Config& c, const std::string& v) { ref(c) = v; }, std::move(doc), std::move(flag));
  }

  // One of `allowed`, kept in a member of another type (an enum): get/set convert.
  template <typename Get, typename Set>
  KeyTable& choice_of(std::string key, std::vector<std::string> allowed, Get get, Set set,
                      std::string doc, std::string flag = {}) {
    KeySpec spec = make(std::move(key), KeyKind::choice, std::move(doc), std::move(flag));
    spec.allowed = std::move(allowed);
    return add(
        std::move(spec), [get](const Config& c) { return Value(get(c)); },
        [set](Config& c, const Value& v) { set(c, std::get<std::string>(v)); });
  }

  const std::vector<KeySpec>& specs() const noexcept { return specs_; }

  // The declaration of `key`, or nullptr.
  const KeySpec* find(const std::string& key) const {
    for (const KeySpec& s : specs_) {
      if (s.key == key) return &s;
    }
    return nullptr;
  }

  // The flag that sets `key`, or empty.
  std::string flag_for(const std::string& key) const {
    const KeySpec* spec = find(key);
    return spec != nullptr ? spec->flag : std::string();
  }

  std::vector<Value> values(const Config& config) const {
    std::vector<Value> out;
    out.reserve(specs_.size());
    for (const Key& k : keys_) out.push_back(k.get(config));
    return out;
  }

  // Reads TOML text over `config` (keys absent keep their value); see read_toml().
  void read_text(const std::string& text, const std::string& origin, Config& config,
                 KeyPositions* positions = nullptr) const {
    check();
    read_toml(
        text, origin, specs_, [&](std::size_t i, Value v) { keys_[i].set(config, v); }, positions);
  }

  void read_file(const std::string& path, Config& config, KeyPositions* positions = nullptr) const {
    read_text(read_config_file(path), path, config, positions);
  }

  // Every key's range or choices; throws ioct::ConfigError naming the first key outside.
  void check_ranges(const Config& config) const {
    for (std::size_t i = 0; i < specs_.size(); ++i) check_value(specs_[i], keys_[i].get(config));
  }

  // The flags given, over the config; throws ioct::ConfigError naming the key.
  void apply(const Overrides& overrides, Config& config) const {
    for (const auto& [key, texts] : overrides) {
      const std::size_t i = index_of(key);
      keys_[i].set(config, value_from_texts(specs_[i], texts));
    }
  }

  std::string to_toml(const Config& config) const { return write_toml(specs_, values(config)); }

  std::string markdown() const { return markdown_table(specs_, values(Config{})); }

  void add_flags_to(CLI::App& app, Overrides& overrides) const {
    check();
    add_flags(app, specs_, values(Config{}), overrides);
  }

 private:
  struct Key {
    std::function<Value(const Config&)> get;
    std::function<void(Config&, const Value&)> set;
  };

  static KeySpec make(std::string key, KeyKind kind, std::string doc, std::string flag) {
    KeySpec spec;
    spec.key = std::move(key);
    spec.kind = kind;
    spec.doc = std::move(doc);
    spec.flag = std::move(flag);
    return spec;
  }

  template <typename Get, typename Set>
  KeyTable& add(KeySpec spec, Get get, Set set) {
    specs_.push_back(std::move(spec));
    keys_.push_back(Key{std::move(get), std::move(set)});
    return *this;
  }

  std::size_t index_of(const std::string& key) const {
    for (std::size_t i = 0; i < specs_.size(); ++i) {
      if (specs_[i].key == key) return i;
    }
    throw std::logic_error("no configuration key " + key);
  }

  // A handful of string comparisons per key, at start-up: cheaper than a mistake in the table.
  void check() const { check_declarations(specs_); }

  std::vector<KeySpec> specs_;
  std::vector<Key> keys_;
};

}  // namespace ioct::config
