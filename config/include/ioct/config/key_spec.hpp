// One configuration key as declared, and what can be done with a key and its value alone: read it
// from a TOML node or from a flag's text, check it, print it. KeyTable (key_table.hpp) ties keys to
// a config struct's members; this part knows nothing of any struct.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "ioct/config/config_file_error.hpp"

namespace CLI {
class App;
}

namespace ioct::config {

// A key's value, whatever its kind: integer kinds hold std::int64_t ("auto" is -1), reals double,
// choices and texts std::string, lists std::vector<std::string>.
using Value = std::variant<std::int64_t, double, bool, std::string, std::vector<std::string>>;

enum class KeyKind { integer, integer_or_auto, real, boolean, text, choice, text_list };

struct KeySpec {
  std::string key;  // its full name, "ring.slots": the file's [ring] slots = ...
  KeyKind kind = KeyKind::integer;
  std::string flag;     // the command-line option that overrides it ("--slots"); empty: none
  std::string doc;      // one line, for --help and the key table in docs/
  std::int64_t lo = 0;  // integer kinds: the range, inclusive
  std::int64_t hi = 0;
  bool real_bounded = false;  // real: checked against [real_lo, real_hi] here; otherwise by
  double real_lo = 0.0;       // the component's own validate()
  double real_hi = 0.0;
  std::vector<std::string> allowed;  // choice

  // The table the key is in ("lines.watchdog" for "lines.watchdog.offset"; "" at the top).
  std::string table() const;
  // The key's own name within its table ("offset").
  std::string name() const;
  // What the key may hold, as the messages and the docs say it: "an integer in [2, 4096]".
  std::string allowed_text() const;
};

// Flags given on a command line: key -> the texts given (one, or several for a list).
using Overrides = std::map<std::string, std::vector<std::string>>;

// Throws ioct::ConfigError naming the key unless `value` is in the key's range or choices.
void check_value(const KeySpec& spec, const Value& value);

// A flag's text as the key's value, checked; throws ioct::ConfigError naming the key.
Value value_from_texts(const KeySpec& spec, const std::vector<std::string>& texts);

// The value as TOML writes it ("4096", "2.0", "\"raster\"", "[\"a\", \"b\"]", "\"auto\"").
std::string toml_text(const KeySpec& spec, const Value& value);

// Reads a configuration's TOML text: each declared key present is checked and handed to
// found(index into specs, value); positions gets where each was. Throws ConfigFileError
// ("origin:line:column: key = value: allowed") for invalid TOML, an empty configuration, a value
// of the wrong type or out of range, and a key or table that is not declared (naming what that
// table takes).
void read_toml(const std::string& text, const std::string& origin,
               const std::vector<KeySpec>& specs,
               const std::function<void(std::size_t, Value)>& found, KeyPositions* positions);

// A configuration file's text: a regular file of at most kMaxConfigBytes that ends with a newline
// (one that does not was most likely cut off part-way: refused). Throws ConfigFileError.
std::string read_config_file(const std::string& path);

// The keys and their values as a TOML document, table by table, in declaration order.
std::string write_toml(const std::vector<KeySpec>& specs, const std::vector<Value>& values);

// The keys as a Markdown table: key, flag, what is allowed, default, doc.
std::string markdown_table(const std::vector<KeySpec>& specs, const std::vector<Value>& defaults);

// Adds each key's flag to the command line; a flag given puts its texts in `overrides`.
void add_flags(CLI::App& app, const std::vector<KeySpec>& specs, const std::vector<Value>& defaults,
               Overrides& overrides);

// Throws std::logic_error unless every key is unique and each table's keys are declared together,
// its own keys before its subtables' (so that write_toml() can print it).
void check_declarations(const std::vector<KeySpec>& specs);

}  // namespace ioct::config
