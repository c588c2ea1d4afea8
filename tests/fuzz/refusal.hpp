// What a parser may do with bad input: refuse it cleanly, with an exception whose message a
// person can read. Anything else is a finding: a crash or sanitizer report (the sanitizers stop
// the run), a hang (-timeout), a memory blow-up (-rss_limit_mb, and std::bad_alloc or
// std::length_error here: a size taken from the input that was not checked before allocating),
// or a message that is empty, echoes control bytes of the input or does not name the file.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>
#include <stdexcept>
#include <string_view>

namespace ioct::fuzz {

[[noreturn]] inline void finding(std::string_view what, std::string_view message) {
  std::fprintf(stderr, "FUZZ FINDING: %.*s\n  message: %.*s\n", static_cast<int>(what.size()),
               what.data(), static_cast<int>(message.size()), message.data());
  std::abort();
}

// A refusal's message: not empty, printable (input is quoted, never echoed raw), and naming
// `must_name` (the file) when one is given.
inline void check_message(std::string_view message, std::string_view must_name = {}) {
  if (message.empty()) finding("refusal with an empty message", message);
  for (const char c : message) {
    const auto byte = static_cast<unsigned char>(c);
    if ((byte < 0x20 && byte != '\n' && byte != '\t') || byte == 0x7f) {
      finding("refusal message with a control byte (input echoed unquoted)", message);
    }
  }
  if (!must_name.empty() && message.find(must_name) == std::string_view::npos) {
    finding("refusal message does not name the file", message);
  }
}

// Runs `parse`; a refusal (any std::exception but the allocation ones) is fine when its message
// passes check_message().
template <typename Parse>
void expect_accept_or_refuse(Parse&& parse, std::string_view must_name = {}) {
  try {
    parse();
  } catch (const std::bad_alloc& e) {
    finding("std::bad_alloc: an allocation sized by the input", e.what());
  } catch (const std::length_error& e) {
    finding("std::length_error: a container sized by the input", e.what());
  } catch (const std::exception& e) {
    check_message(e.what(), must_name);
  }
}

}  // namespace ioct::fuzz
