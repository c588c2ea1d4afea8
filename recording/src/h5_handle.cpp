#include "ioct/ringrec/h5_handle.hpp"

namespace ioct::ringrec {
namespace {

herr_t collect(unsigned n, const H5E_error2_t* error, void* data) {
  auto& text = *static_cast<std::string*>(data);
  if (n >= 3) return 0;  // the innermost few say what went wrong; the rest is call chain
  if (!text.empty()) text += "; ";
  text += error->func_name != nullptr ? error->func_name : "?";
  text += ": ";
  text += error->desc != nullptr ? error->desc : "?";
  return 0;
}

}  // namespace

std::string h5_error_stack() {
  std::string text;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, collect, &text);
  H5Eclear2(H5E_DEFAULT);
  return text;
}

herr_t h5_check(herr_t status, const std::string& what) {
  if (status < 0) {
    const std::string stack = h5_error_stack();
    throw H5Error(what + (stack.empty() ? std::string() : ": " + stack));
  }
  return status;
}

hid_t h5_check_id(hid_t id, const std::string& what) {
  if (id < 0) {
    const std::string stack = h5_error_stack();
    throw H5Error(what + (stack.empty() ? std::string() : ": " + stack));
  }
  return id;
}

void h5_quiet() {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

}  // namespace ioct::ringrec
