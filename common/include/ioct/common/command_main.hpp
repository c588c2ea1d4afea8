// How every command of the project ends: its body runs under run_command(), and an exception
// becomes one line on stderr in the words of its category and the exit status of the one rule
// (error.hpp), instead of a catch ladder in each main.
#pragma once

#include <functional>
#include <string>
#include <string_view>

namespace ioct {

// The command-line flag that sets a configuration key ("--slots" for "ring.slots"), or empty.
using FlagForKey = std::function<std::string(const std::string& key)>;

// Runs `body` and returns its status. An exception from it is told on stderr as
// "<program>: <words>: <what()>", the words from its category ("invalid configuration", "bad
// input", "device error", "error"), followed by " (option --flag)" when `flag_for` names the flag
// of the error's key, and returns exit_status(category_of(e)).
int run_command(std::string_view program, const std::function<int()>& body,
                const FlagForKey& flag_for = {});

// The line run_command() writes for `e`, without the newline (for tests and for commands that
// go on after an error, e.g. to keep what they already wrote).
std::string describe_failure(std::string_view program, const std::exception& e,
                             const FlagForKey& flag_for = {});

}  // namespace ioct
