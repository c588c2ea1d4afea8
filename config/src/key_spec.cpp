#include "ioct/config/key_spec.hpp"

#include <toml++/toml.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>
#include <stdexcept>

#include "ioct/common/config_error.hpp"
#include "ioct/common/input_file.hpp"

namespace ioct::config {
namespace {

std::string joined(const std::vector<std::string>& items, std::string_view last = ", ") {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i > 0) out += i + 1 == items.size() ? std::string(last) : std::string(", ");
    out += items[i];
  }
  return out;
}

std::string type_name(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::table:
      return "a table";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a number";
    case toml::node_type::boolean:
      return "a boolean";
    default:
      return "a date or time";
  }
}

std::string shown_value(const toml::node& node) {
  if (const auto* s = node.as_string()) return format_text(s->get());
  std::ostringstream out;
  node.visit([&](const auto& n) { out << n; });
  return out.str();
}

SourcePosition position_of(const toml::source_region& source) {
  return {static_cast<std::uint32_t>(source.begin.line),
          static_cast<std::uint32_t>(source.begin.column)};
}

[[noreturn]] void wrong_type(const std::string& origin, const std::string& key,
                             const toml::node& node, std::string_view wanted) {
  throw ConfigFileError(origin, position_of(node.source()),
                        ConfigError(key, shown_value(node),
                                    "must be " + std::string(wanted) + ", not " + type_name(node))
                            .what());
}

std::string range_text(std::int64_t lo, std::int64_t hi) {
  return "[" + format_value(lo) + ", " + format_value(hi) + "]";
}

// The node's value as the key's kind, or a ConfigFileError at the node.
Value value_of(const KeySpec& spec, const toml::node& node, const std::string& origin) {
  switch (spec.kind) {
    case KeyKind::integer_or_auto:
      if (const auto* text = node.as_string()) {
        if (text->get() != "auto") {
          throw ConfigFileError(
              origin, position_of(node.source()),
              ConfigError(spec.key, format_text(text->get()), spec.allowed_text()).what());
        }
        return std::int64_t{-1};
      }
      if (const auto* v = node.as_integer(); v != nullptr && v->get() == -1) {
        // -1 is how the member keeps "auto"; the file says "auto".
        throw ConfigFileError(origin, position_of(node.source()),
                              ConfigError(spec.key, "-1", spec.allowed_text()).what());
      }
      [[fallthrough]];
    case KeyKind::integer:
      if (const auto* v = node.as_integer()) return v->get();
      wrong_type(origin, spec.key, node, "an integer");
    case KeyKind::real:
      if (const auto* f = node.as_floating_point()) return f->get();
      if (const auto* i = node.as_integer()) return static_cast<double>(i->get());
      wrong_type(origin, spec.key, node, "a number");
    case KeyKind::boolean:
      if (const auto* b = node.as_boolean()) return b->get();
      wrong_type(origin, spec.key, node, "true or false");
    case KeyKind::text:
    case KeyKind::choice:
      if (const auto* s = node.as_string()) return s->get();
      wrong_type(origin, spec.key, node, "a string");
    case KeyKind::text_list: {
      const auto* array = node.as_array();
      if (array == nullptr) wrong_type(origin, spec.key, node, "an array of strings");
      std::vector<std::string> items;
      for (const toml::node& item : *array) {
        const auto* s = item.as_string();
        if (s == nullptr) wrong_type(origin, spec.key, item, "an array of strings");
        items.push_back(s->get());
      }
      return items;
    }
  }
  throw std::logic_error("unknown key kind");
}

bool is_table_of(const std::vector<KeySpec>& specs, const std::string& name) {
  return std::any_of(specs.begin(), specs.end(), [&](const KeySpec& s) {
    return s.key.size() > name.size() && s.key.compare(0, name.size(), name) == 0 &&
           s.key[name.size()] == '.';
  });
}

// The names directly in table `prefix` ("" for the file), in declaration order.
std::vector<std::string> names_in(const std::vector<KeySpec>& specs, const std::string& prefix) {
  std::vector<std::string> names;
  for (const KeySpec& s : specs) {
    if (!prefix.empty() && (s.key.size() <= prefix.size() + 1 ||
                            s.key.compare(0, prefix.size() + 1, prefix + ".") != 0)) {
      continue;
    }
    const std::string rest = prefix.empty() ? s.key : s.key.substr(prefix.size() + 1);
    const std::string name = rest.substr(0, rest.find('.'));
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  }
  return names;
}

// Refuses every key of `table` (at `prefix`) that is neither declared nor a declared table.
void refuse_unknown(const toml::table& table, const std::string& prefix,
                    const std::vector<KeySpec>& specs, const std::string& origin) {
  for (auto&& [key, node] : table) {
    const std::string full =
        prefix.empty() ? std::string(key.str()) : prefix + "." + std::string(key.str());
    // A quoted key with a dot in it ("realtime.priority" = 0) names no declared key: were it
    // taken for one, its value would be ignored without a word.
    const bool dotted = key.str().find('.') != std::string_view::npos;
    const bool declared = !dotted && std::any_of(specs.begin(), specs.end(),
                                                 [&](const KeySpec& s) { return s.key == full; });
    if (declared) continue;
    if (!dotted && is_table_of(specs, full)) {
      if (const auto* sub = node.as_table()) refuse_unknown(*sub, full, specs, origin);
      continue;  // not a table: refused where its keys were looked for
    }
    // A quoted TOML key may hold any character: shown printable.
    throw ConfigFileError(origin, position_of(key.source()),
                          quote_input(full, 80) + ": unknown key; " +
                              (prefix.empty() ? std::string("the file") : "[" + prefix + "]") +
                              " takes " + joined(names_in(specs, prefix)));
  }
}

// The node of `spec` in the document, or nullptr; a table on its path that is something else is
// refused.
const toml::node* find_node(const toml::table& root, const KeySpec& spec,
                            const std::string& origin) {
  const toml::table* table = &root;
  std::string path;
  std::size_t begin = 0;
  while (true) {
    const std::size_t dot = spec.key.find('.', begin);
    const std::string part = spec.key.substr(begin, dot == std::string::npos ? dot : dot - begin);
    path += (path.empty() ? "" : ".") + part;
    const toml::node* node = table->get(part);
    if (node == nullptr || dot == std::string::npos) return node;
    table = node->as_table();
    if (table == nullptr) wrong_type(origin, path, *node, "a table");
    begin = dot + 1;
  }
}

// Text in a Markdown table cell: its bars escaped, so the row keeps its columns.
std::string cell(std::string_view text) {
  std::string out;
  for (const char c : text) {
    if (c == '|') out += '\\';
    out += c;
  }
  return out;
}

// Whether `text` is UTF-8, as a TOML string must be.
bool is_utf8(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    const auto byte = static_cast<unsigned char>(text[i]);
    std::size_t length = 0;
    if (byte < 0x80) {
      length = 1;
    } else if ((byte >> 5) == 0x6) {
      length = 2;
    } else if ((byte >> 4) == 0xE) {
      length = 3;
    } else if ((byte >> 3) == 0x1E) {
      length = 4;
    }
    if (length == 0 || i + length > text.size()) return false;
    for (std::size_t k = 1; k < length; ++k) {
      if ((static_cast<unsigned char>(text[i + k]) & 0xC0) != 0x80) return false;
    }
    i += length;
  }
  return true;
}

std::string toml_string(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      char escape[8];
      std::snprintf(escape, sizeof(escape), "\\u%04x", static_cast<unsigned char>(c));
      out += escape;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

}  // namespace

ConfigFileError::ConfigFileError(const std::string& file, SourcePosition position,
                                 const std::string& message)
    : std::runtime_error(file + ":" + std::to_string(position.line) + ":" +
                         std::to_string(position.column) + ": " + message),
      Error(ErrorCategory::config),
      file_(file),
      position_(position) {}

std::string KeySpec::table() const {
  const std::size_t dot = key.rfind('.');
  return dot == std::string::npos ? std::string() : key.substr(0, dot);
}

std::string KeySpec::name() const {
  const std::size_t dot = key.rfind('.');
  return dot == std::string::npos ? key : key.substr(dot + 1);
}

std::string KeySpec::allowed_text() const {
  switch (kind) {
    case KeyKind::integer:
      return "must be in " + range_text(lo, hi);
    case KeyKind::integer_or_auto:
      return "must be \"auto\" or an integer in " + range_text(lo, hi);
    case KeyKind::real:
      return real_bounded
                 ? "must be in [" + format_value(real_lo) + ", " + format_value(real_hi) + "]"
                 : "must be a number";
    case KeyKind::boolean:
      return "must be true or false";
    case KeyKind::choice:
      return "must be one of " + joined(allowed);
    case KeyKind::text:
      return "must be a string";
    case KeyKind::text_list:
      return "must be an array of strings";
  }
  return {};
}

void check_value(const KeySpec& spec, const Value& value) {
  switch (spec.kind) {
    case KeyKind::integer:
    case KeyKind::integer_or_auto: {
      const std::int64_t v = std::get<std::int64_t>(value);
      if (spec.kind == KeyKind::integer_or_auto && v == -1) return;
      if (v < spec.lo || v > spec.hi)
        throw ConfigError(spec.key, format_value(v), spec.allowed_text());
      return;
    }
    case KeyKind::real:
      if (spec.real_bounded)
        require_real_in_range(spec.key, std::get<double>(value), spec.real_lo, spec.real_hi);
      return;
    case KeyKind::choice: {
      const std::string& v = std::get<std::string>(value);
      if (std::find(spec.allowed.begin(), spec.allowed.end(), v) == spec.allowed.end()) {
        throw ConfigError(spec.key, format_text(v), spec.allowed_text());
      }
      return;
    }
    case KeyKind::boolean:
    case KeyKind::text:
    case KeyKind::text_list:
      return;
  }
}

Value value_from_texts(const KeySpec& spec, const std::vector<std::string>& texts) {
  for (const std::string& text : texts) {
    // The printed configuration must read back; a file's strings are UTF-8 already (TOML).
    if (!is_utf8(text)) throw ConfigError(spec.key, format_text(text), "must be UTF-8 text");
  }
  if (spec.kind == KeyKind::text_list) return texts;
  if (texts.size() != 1) {
    throw ConfigError(spec.key, format_value(std::uint64_t{texts.size()}) + " values",
                      "takes one value");
  }
  const std::string& text = texts.front();
  Value value;
  switch (spec.kind) {
    case KeyKind::integer_or_auto:
      if (text == "auto") return std::int64_t{-1};
      [[fallthrough]];
    case KeyKind::integer: {
      std::int64_t v = 0;
      const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), v);
      if (error != std::errc() || end != text.data() + text.size()) {
        throw ConfigError(spec.key, format_text(text),
                          spec.kind == KeyKind::integer
                              ? "must be an integer in " + range_text(spec.lo, spec.hi)
                              : spec.allowed_text());
      }
      value = v;
      break;
    }
    case KeyKind::real: {
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
        throw ConfigError(spec.key, format_text(text), "must be a finite number");
      }
      value = v;
      break;
    }
    case KeyKind::boolean:
      if (text != "true" && text != "false") {
        throw ConfigError(spec.key, format_text(text), "must be true or false");
      }
      value = text == "true";
      break;
    case KeyKind::text:
    case KeyKind::choice:
    case KeyKind::text_list:
      value = text;
      break;
  }
  check_value(spec, value);
  return value;
}

std::string toml_text(const KeySpec& spec, const Value& value) {
  switch (spec.kind) {
    case KeyKind::integer_or_auto:
      if (std::get<std::int64_t>(value) == -1) return "\"auto\"";
      [[fallthrough]];
    case KeyKind::integer:
      return format_value(std::get<std::int64_t>(value));
    case KeyKind::real: {
      std::string v = format_value(std::get<double>(value));
      if (v.find_first_of(".eEn") == std::string::npos) v += ".0";  // a float in TOML
      return v;
    }
    case KeyKind::boolean:
      return std::get<bool>(value) ? "true" : "false";
    case KeyKind::text:
    case KeyKind::choice:
      return toml_string(std::get<std::string>(value));
    case KeyKind::text_list: {
      std::vector<std::string> items;
      for (const std::string& s : std::get<std::vector<std::string>>(value)) {
        items.push_back(toml_string(s));
      }
      return "[" + joined(items) + "]";
    }
  }
  return {};
}

void read_toml(const std::string& text, const std::string& origin,
               const std::vector<KeySpec>& specs,
               const std::function<void(std::size_t, Value)>& found, KeyPositions* positions) {
  toml::table root;
  try {
    root = toml::parse(text, origin);
  } catch (const toml::parse_error& e) {
    throw ConfigFileError(origin, position_of(e.source()),
                          "not valid TOML: " + quote_input(e.description(), 240));
  }
  if (root.empty()) {
    const SourcePosition end{
        static_cast<std::uint32_t>(std::count(text.begin(), text.end(), '\n') + 1), 1};
    throw ConfigFileError(origin, end,
                          "the configuration is empty (no table, no key): refusing it rather "
                          "than running on defaults");
  }
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const toml::node* node = find_node(root, specs[i], origin);
    if (node == nullptr) continue;
    Value value = value_of(specs[i], *node, origin);
    try {
      check_value(specs[i], value);
    } catch (const ConfigError& e) {
      throw ConfigFileError(origin, position_of(node->source()), e.what());
    }
    if (positions != nullptr) (*positions)[specs[i].key] = position_of(node->source());
    found(i, std::move(value));
  }
  refuse_unknown(root, "", specs, origin);
}

ConfigFileError::ConfigFileError(const std::string& file, const std::string& message)
    : std::runtime_error(message), Error(ErrorCategory::config), file_(file) {}

std::string read_config_file(const std::string& path) {
  std::string text;
  try {
    text = read_small_file(path, "the configuration file", kMaxConfigBytes);
  } catch (const InputFileError& e) {
    // The configuration, not the data, is what cannot be used: refused as a configuration is.
    throw ConfigFileError(path, e.what());
  }
  // A file cut off part-way (a partial copy) mostly ends inside a line: refused. One cut at a
  // line end still misses its later keys, which a process may require (ioct-rt with hardware).
  if (!text.empty() && text.back() != '\n') {
    const auto lines = static_cast<std::uint32_t>(std::count(text.begin(), text.end(), '\n') + 1);
    throw ConfigFileError(path, {lines, 1},
                          "the file does not end with a newline: it looks cut off (a partial "
                          "copy?); refusing it");
  }
  return text;
}

std::string write_toml(const std::vector<KeySpec>& specs, const std::vector<Value>& values) {
  std::string out;
  std::string table;
  for (std::size_t i = 0; i < specs.size(); ++i) {
    if (specs[i].table() != table) {
      table = specs[i].table();
      out += "\n[" + table + "]\n";
    }
    out += specs[i].name() + " = " + toml_text(specs[i], values[i]) + "\n";
  }
  return out;
}

std::string markdown_table(const std::vector<KeySpec>& specs, const std::vector<Value>& defaults) {
  std::string out = "| key | flag | allowed | default | what it sets |\n|---|---|---|---|---|\n";
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const KeySpec& s = specs[i];
    std::string allowed = s.allowed_text();
    if (allowed.rfind("must be ", 0) == 0) allowed = allowed.substr(8);
    out += "| `" + s.key + "` | " + (s.flag.empty() ? "" : "`" + s.flag + "`") + " | " +
           cell(allowed) + " | `" + cell(toml_text(s, defaults[i])) + "` | " + cell(s.doc) + " |\n";
  }
  return out;
}

void add_flags(CLI::App& app, const std::vector<KeySpec>& specs, const std::vector<Value>& defaults,
               Overrides& overrides) {
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const KeySpec& s = specs[i];
    if (s.flag.empty()) continue;
    const std::string help = s.key + ": " + s.doc;
    const std::string key = s.key;
    if (s.kind == KeyKind::boolean) {
      // "--no-x" sets its key false, any other boolean flag true; "--x=false" (CLI11 gives a
      // negative count) the opposite.
      const bool sets = s.flag.rfind("--no-", 0) != 0;
      app.add_flag_function(
          s.flag,
          [&overrides, key, sets](std::int64_t count) {
            overrides[key] = {(count > 0) == sets ? "true" : "false"};
          },
          help);
    } else if (s.kind == KeyKind::text_list) {
      app.add_option_function<std::vector<std::string>>(
             s.flag, [&overrides, key](const std::vector<std::string>& v) { overrides[key] = v; },
             help + "; repeatable")
          ->type_name("TEXT");
    } else {
      const char* type = s.kind == KeyKind::integer  ? "INT"
                         : s.kind == KeyKind::real   ? "NUMBER"
                         : s.kind == KeyKind::choice ? "CHOICE"
                                                     : "TEXT";
      std::string shown = toml_text(s, defaults[i]);
      if (s.kind == KeyKind::choice || s.kind == KeyKind::text)
        shown = std::get<std::string>(defaults[i]);
      app.add_option_function<std::string>(
             s.flag, [&overrides, key](const std::string& v) { overrides[key] = {v}; },
             s.kind == KeyKind::choice ? help + " (" + joined(s.allowed, " or ") + ")" : help)
          ->type_name(type)
          ->default_str(shown);
    }
  }
}

void check_declarations(const std::vector<KeySpec>& specs) {
  std::set<std::string> keys;
  std::set<std::string> flags;
  std::set<std::string> closed;  // tables whose keys have all been declared
  std::string table;
  bool first = true;
  for (const KeySpec& s : specs) {
    if (s.key.empty() || !keys.insert(s.key).second) {
      throw std::logic_error("configuration key declared twice or empty: " + s.key);
    }
    if (!s.flag.empty() && !flags.insert(s.flag).second) {
      throw std::logic_error("flag " + s.flag + " sets two keys");
    }
    if (s.table().empty() && !first && !table.empty()) {
      throw std::logic_error(s.key + ": a key outside any table must come before every table");
    }
    if (first || s.table() != table) {
      if (!first) closed.insert(table);
      if (closed.contains(s.table())) {
        throw std::logic_error("the keys of [" + s.table() +
                               "] must be declared together, its own before its subtables'");
      }
      table = s.table();
      first = false;
    }
    if (s.kind == KeyKind::choice && s.allowed.empty()) {
      throw std::logic_error(s.key + ": a choice with nothing to choose");
    }
  }
  for (const KeySpec& s : specs) {
    if (is_table_of(specs, s.key)) throw std::logic_error(s.key + " is both a key and a table");
  }
}

}  // namespace ioct::config
